"""The seed paper's method end to end: V.A global motion, V.B Bezier velocity, V.C refinement.

Liang, Chang & Chen, "Analysis and Compensation of Rolling Shutter Effect", IEEE TIP
17(8), 2008, Fig. 5. For each pair of consecutive frames the global motion ``g(n)``
(:mod:`~unjello.motion.paper.global_motion`) gives a velocity sample (eq. 13); the samples are
interpolated per scanline by cubic Bezier curves (:mod:`~unjello.motion.paper.velocity`,
eq. 14-19); local block matching under the constraints of eq. 22-23 refines them
(:mod:`~unjello.motion.paper.refine`, eq. 24-25), iterated; the scanline displacement of
eq. 26 is then applied by :mod:`unjello.warp.warper`.

Streaming: the method receives frames one at a time and returns each frame's
:class:`~unjello.trajectory.FrameMotion` two frames later (frame ``n`` needs the global
samples up to ``g(n + 2)`` and the local samples of the pairs ``(n-1, n)`` and
``(n, n+1)``), holding at most four frames.

The still first frame (eq. 11)
------------------------------
The paper assumes the camera is still during the first frame, so that the middle
scanline of every frame sits where the global-shutter frame would have it. Eq. 26 only
needs the velocity *within* a frame, relative to that frame's reference scanline, so
a clip that starts moving is corrected the same way; what the first frame lacks is the
pair before it, and its velocity comes from the samples after it (clamped, see
:mod:`~unjello.motion.paper.velocity`). When the first frame moves, the corrected clip is
the global-shutter clip at each frame's reference time: it is not, and cannot be,
aligned to a still first frame.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import numpy as np

from ...timing import SensorTiming, scanline_displacement
from ...trajectory import FrameMotion
from .global_motion import BlockMatchConfig, global_motion
from .refine import (
    LocalMatches,
    RefineConfig,
    better_matches,
    inside_constraints,
    local_block_match,
    predict_local_motion,
    refined_velocity,
    row_samples,
)
from .velocity import global_sample_time, initial_velocity, scanline_velocity

__all__ = ["PaperConfig", "PaperMethod"]

#: A frame is left as is where the velocity leaves its block rows this share of their spread
#: (mean absolute deviation, px) uncorrected, that being over :data:`SHEAR_FLOOR`.
UNEXPLAINED = 0.85
SHEAR_FLOOR = 0.2
#: A frame pair whose global motion and every local sample are below this (px) is still.
STILL = 0.05


def _merge(lm: LocalMatches, far: np.ndarray, around_g: LocalMatches) -> LocalMatches:
    """``lm`` with its ``far`` blocks' better match among theirs and ``around_g``'s."""
    sub = LocalMatches(lm.centers[far], lm.motion[far], lm.residual[far], lm.accepted[far])
    best = better_matches(sub, around_g)
    motion, residual, accepted = lm.motion.copy(), lm.residual.copy(), lm.accepted.copy()
    motion[far], residual[far], accepted[far] = best.motion, best.residual, best.accepted
    return LocalMatches(lm.centers, motion, residual, accepted)


@dataclass(frozen=True)
class PaperConfig:
    """Settings of the paper's method.

    Parameters
    ----------
    global_motion : BlockMatchConfig
        Sec. V.A block matching (16x16 blocks, +/-160 px).
    refine : RefineConfig
        Sec. V.C local refinement (3 iterations).
    """

    global_motion: BlockMatchConfig = field(default_factory=BlockMatchConfig)
    refine: RefineConfig = field(default_factory=RefineConfig)


@dataclass
class _Pair:
    """Samples measured between frames k-1 and k."""

    g_time: float
    g_value: np.ndarray
    g_ok: bool
    g_vector: np.ndarray = field(default_factory=lambda: np.zeros(2))
    local_t: np.ndarray = field(default_factory=lambda: np.zeros(0))
    local_v: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    # The same samples as rows of frame k and their local motion l to frame k-1 (eq. 24)
    local_y: np.ndarray = field(default_factory=lambda: np.zeros(0))
    local_l: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))


class PaperMethod:
    """Streaming implementation of Sec. V.A-V.C.

    Parameters
    ----------
    timing : SensorTiming
        Readout and reference; frames must already be in top-bottom orientation.
    config : PaperConfig
        Stage settings.

    Examples
    --------
    >>> m = PaperMethod(SensorTiming(1.0))
    >>> rng = np.random.default_rng(1)
    >>> scene = rng.uniform(0, 255, (80, 400)).astype(np.float32)
    >>> out = []
    >>> for n in range(4):
    ...     out += m.push(scene[:, 40 - 3 * n:200 - 3 * n].copy(), float(n))
    >>> out += m.flush()
    >>> [round(float(f.velocity[:, 0].mean()), 2) for f in out]
    [3.0, 3.0, 3.0, 3.0]
    """

    def __init__(self, timing: SensorTiming, config: PaperConfig = PaperConfig()) -> None:
        self.timing = timing
        self.config = config
        self._frames: deque[tuple[int, float, np.ndarray]] = deque(maxlen=3)
        self._pending: deque[tuple[int, float, int]] = deque()
        self._pairs: dict[int, _Pair] = {}
        self._count = 0
        self._last_g = (0.0, 0.0)
        self._last_curve: tuple[int, np.ndarray] | None = None  # (frame, its Bezier D)

    # -- sample bookkeeping ------------------------------------------------------------
    def _samples(self, exclude_local: int | None = None, local: bool = True
                 ) -> tuple[np.ndarray, np.ndarray]:
        ts, vs = [], []
        for k, pair in self._pairs.items():
            # A pair's local samples replace its g(n) (Sec. V.C adds them to it: see
            # :mod:`~unjello.motion.paper.refine` for why not).
            if local and pair.local_t.size >= 2 and k != exclude_local:
                ts.append(pair.local_t)
                vs.append(pair.local_v)
            elif pair.g_ok:
                ts.append(np.array([pair.g_time]))
                vs.append(pair.g_value[None])
        if not ts:
            return np.zeros(0), np.zeros((0, 2))
        t = np.concatenate(ts)
        v = np.concatenate(vs)
        t, uniq = np.unique(t, return_index=True)
        return t, v[uniq]

    def _velocity(self, times: np.ndarray, exclude_local: int | None = None) -> np.ndarray:
        t, v = self._samples(exclude_local)
        return scanline_velocity(t, v, times)

    # -- stages ------------------------------------------------------------------------
    def _global(self, k: int, prev: tuple[int, float, np.ndarray],
                cur: tuple[int, float, np.ndarray]) -> None:
        """Sec. V.A and eq. 13 for the pair (k-1, k)."""
        h = cur[2].shape[0]
        gm = global_motion(prev[2], cur[2], self.config.global_motion, hint=self._last_g)
        dt = cur[1] - prev[1]
        if gm:
            self._last_g = (float(gm.vector[0]), float(gm.vector[1]))
        self._pairs[k] = _Pair(
            g_time=global_sample_time(prev[1], cur[1], self.timing.readout, h,
                                      float(gm.vector[1])),
            g_value=initial_velocity(gm.vector, dt, self.timing.readout, h),
            g_ok=bool(gm),
            g_vector=np.asarray(gm.vector, dtype=np.float64),
        )

    def _refine(self, k: int, prev: tuple[int, float, np.ndarray],
                cur: tuple[int, float, np.ndarray]) -> None:
        """Sec. V.C, eq. 22-25, iterated, for the pair (k-1, k)."""
        cfg = self.config.refine
        p_img, c_img = prev[2], cur[2]
        h, w = c_img.shape
        rho = self.timing.readout
        dt = cur[1] - prev[1]
        b = cfg.block
        ys, xs = np.mgrid[b // 2:h - b // 2 + 1:b, b // 2:w - b // 2 + 1:b]
        centers = np.stack([xs.ravel(), ys.ravel()], axis=1).astype(np.float64)
        margin = (b / 2 + cfg.radius, b / 2 + cfg.radius)
        pair = self._pairs[k]
        for _ in range(cfg.iterations):
            t_rows = cur[1] + rho * centers[:, 1] / h
            v_pred = self._velocity(t_rows)
            l_pred = predict_local_motion(v_pred, dt, rho, h)
            inside = inside_constraints(centers, l_pred, (w, h), margin)
            sel = centers[inside]
            if sel.shape[0] == 0:
                break
            lm = local_block_match(p_img, c_img, sel, l_pred[inside], cfg)
            # Where the curve's prediction strays from g(n) by more than the window, a
            # second window around g(n) (the search range eq. 22-23 would allow).
            far = np.abs(l_pred[inside] - pair.g_vector).max(axis=1) > cfg.radius
            if pair.g_ok and far.any():
                around_g = local_block_match(p_img, c_img, sel[far],
                                             np.broadcast_to(pair.g_vector, (int(far.sum()), 2)),
                                             cfg)
                lm = _merge(lm, far, around_g)
            v = refined_velocity(lm.motion, dt, rho, h)
            s1_t = cur[1] + rho * sel[:, 1] / h
            s2_t = prev[1] + rho * (sel[:, 1] - lm.motion[:, 1]) / h
            t_s, v_s = row_samples(lm, v, 0.5 * (s1_t + s2_t), b, cfg.min_blocks)
            # No sample beyond what the global search could have measured.
            measurable = np.abs(v_s).max(axis=1, initial=0.0) <= self.config.global_motion.search
            t_s, v_s = t_s[measurable], v_s[measurable]
            if t_s.size < 2:
                break
            pair.local_t, pair.local_v = t_s, v_s
            # Back from the samples to their rows and local motions (eq. 25 and the
            # sample time, inverted).
            pair.local_l = predict_local_motion(v_s, dt, rho, h)
            pair.local_y = ((t_s - 0.5 * (prev[1] + cur[1])) * 2 * h / max(rho, 1e-9)
                            + pair.local_l[:, 1]) / 2

    def _frame_velocity(self, times: np.ndarray) -> tuple[np.ndarray, bool]:
        """Return the Bezier velocity at ``times``, and whether the samples diverged.

        Where they diverged (a velocity beyond what the global search could have
        measured), the global motion's alone (Sec. V.B) is returned instead.
        """
        vel = self._velocity(times)
        if np.isfinite(vel).all() and np.abs(vel).max() <= self.config.global_motion.search:
            return vel, False
        t, v = self._samples(local=False)
        return scanline_velocity(t, v, times), True

    def _emit(self, n: int, start: float, height: int) -> FrameMotion:
        times = self.timing.row_times(height, start)
        vel, diverged = self._frame_velocity(times)
        ok = any(p.g_ok for k, p in self._pairs.items() if k in (n, n + 1))
        notes = ["" if ok else "no global motion found near this frame; velocity bridged",
                 "local samples diverged: the global motion alone used" if diverged else ""]
        events = (() if ok else ("bridged",)) + (("diverged",) if diverged else ())
        disp = scanline_displacement(vel, self.timing)
        curve = disp
        vel, disp, said, why = self._do_no_harm(n, times, vel, disp)
        self._last_curve = (n, curve)  # the next frame is judged against it, not a choice
        return FrameMotion(n, start, disp, vel, ok=ok,
                           note="; ".join(x for x in (*notes, said) if x),
                           events=events + ((why,) if why else ()))

    def _do_no_harm(self, n: int, times: np.ndarray, vel: np.ndarray, disp: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray, str, str]:
        """Do no harm: keep the correction under which frame n agrees with its neighbours.

        Two global-shutter frames of a translating camera differ by one translation, so
        after a right correction every block row of a frame has moved from the frame
        before by the same vector. With the block rows' local motions ``l(y)`` (eq. 24)
        and the corrections ``D`` (eq. 26) of both frames, a row's corrected motion is
        ``l(y) - D_k(y) + D_{k-1}(y - l_y)``; its spread over the rows is measured for the
        pairs (n-1, n) and (n, n+1), with the neighbours' Bezier corrections. Where the
        curve barely makes them agree better than no correction (a vibration faster than
        the curve can follow, which it follows out of phase), the frame is left as is.
        And a frame next to a pair that shows no motion at all was read while the camera
        stood still (the frame after a sudden stop, before a start, which the curve
        reaches into: the paper's Fig. 7): it is left as is too. Either is said in the
        frame's note, and as an event (``still``, ``unexplained``;
        :data:`~unjello.trajectory.EVENTS`).
        """
        h = disp.shape[0]
        # (pair, earlier frame's D, later frame's D); None: the candidate
        checks: list[tuple[_Pair, np.ndarray | None, np.ndarray | None]] = []
        last = self._last_curve
        back = self._pairs.get(n)
        if back is not None and back.local_y.size >= 4 and last is not None and last[0] == n - 1:
            checks.append((back, last[1], None))
        ahead = self._pairs.get(n + 1)
        nxt = next((p for p in self._pending if p[0] == n + 1), None)
        if ahead is not None and ahead.local_y.size >= 4 and nxt is not None:
            later = scanline_displacement(
                self._frame_velocity(self.timing.row_times(h, nxt[1]))[0], self.timing)
            checks.append((ahead, None, later))
        if not checks or self.timing.readout <= 0:
            return vel, disp, "", ""
        rows = np.arange(h, dtype=np.float64)

        def at(d: np.ndarray, where: np.ndarray) -> np.ndarray:
            return np.stack([np.interp(where, rows, d[:, k]) for k in range(2)], axis=1)

        def spread(d: np.ndarray) -> float:
            total = 0.0
            for pair, earlier, later in checks:
                y, local = pair.local_y, pair.local_l
                moved = (local - at(d if later is None else later, y)
                         + at(d if earlier is None else earlier, y - local[:, 1]))
                total += float(np.abs(moved - np.median(moved, axis=0)).mean(axis=0).sum())
            return total / len(checks)

        # A frame next to a still pair was read while the camera stood still: the pair's
        # rows cover [t_{n-1}, t_n + rho] (or [t_n, t_{n+1} + rho]), all of its readout.
        for pair, _, _ in checks:
            if pair.g_ok and np.abs(pair.g_vector).max() < STILL and \
                    np.abs(pair.local_l).max() < STILL:
                return np.zeros_like(vel), np.zeros_like(disp), (
                    "still: a neighbouring frame shows no motion at all"), "still"
        curve, still = spread(disp), spread(np.zeros_like(disp))
        if still > SHEAR_FLOOR and curve > UNEXPLAINED * still:
            return np.zeros_like(vel), np.zeros_like(disp), (
                "frame left as is: the Bezier velocity does not explain its motion (block "
                f"rows {curve:.2f} px apart with it, {still:.2f} px without; a vibration?)"
            ), "unexplained"
        return vel, disp, "", ""

    # -- streaming API -----------------------------------------------------------------
    def push(self, frame: np.ndarray, start: float) -> list[FrameMotion]:
        """Add the next frame (grey, 0-255, top-bottom) starting at time ``start``.

        Returns
        -------
        list of FrameMotion
            The frames whose motion is now final (lagging two frames behind).
        """
        k = self._count
        self._count += 1
        item = (k, float(start), np.asarray(frame, dtype=np.float32))
        if self._frames:
            self._global(k, self._frames[-1], item)
        self._frames.append(item)
        self._pending.append((k, float(start), item[2].shape[0]))
        # Refine the pair (k-2, k-1) once g(k) is known, so its prediction sees ahead.
        if k >= 2:
            self._refine(k - 1, self._frames[-3], self._frames[-2])
        return self._ready(final=False)

    def flush(self) -> list[FrameMotion]:
        """Finish the clip: refine the last pair and return the remaining frames."""
        if len(self._frames) >= 2:
            self._refine(self._count - 1, self._frames[-2], self._frames[-1])
        return self._ready(final=True)

    def _ready(self, final: bool) -> list[FrameMotion]:
        out = []
        while self._pending and (final or self._count - 1 >= self._pending[0][0] + 2):
            n, start, height = self._pending.popleft()
            out.append(self._emit(n, start, height))
            for k in [k for k in self._pairs if k < n - 1]:
                del self._pairs[k]
        return out
