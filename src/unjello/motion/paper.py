"""The seed paper's method end to end: V.A global motion, V.B Bezier velocity, V.C refinement.

Liang, Chang & Chen, "Analysis and Compensation of Rolling Shutter Effect", IEEE TIP
17(8), 2008, Fig. 5. For each pair of consecutive frames the global motion ``g(n)``
(:mod:`~unjello.motion.global_motion`) gives a velocity sample (eq. 13); the samples are
interpolated per scanline by cubic Bezier curves (:mod:`~unjello.motion.velocity`,
eq. 14-19); local block matching under the constraints of eq. 22-23 refines them
(:mod:`~unjello.motion.refine`, eq. 24-25), iterated; the scanline displacement of
eq. 26 is then applied by :mod:`unjello.warp`.

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
:mod:`~unjello.motion.velocity`). When the first frame moves, the corrected clip is
the global-shutter clip at each frame's reference time: it is not, and cannot be,
aligned to a still first frame.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import numpy as np

from ..timing import SensorTiming
from ..trajectory import FrameMotion, scanline_displacement
from .global_motion import BlockMatchConfig, global_motion
from .refine import (
    RefineConfig,
    inside_constraints,
    local_block_match,
    predict_local_motion,
    refined_velocity,
    row_samples,
)
from .velocity import global_sample_time, initial_velocity, scanline_velocity

__all__ = ["PaperConfig", "PaperMethod"]


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
    local_t: np.ndarray = field(default_factory=lambda: np.zeros(0))
    local_v: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))


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

    # -- sample bookkeeping ------------------------------------------------------------
    def _samples(self, exclude_local: int | None = None, local: bool = True
                 ) -> tuple[np.ndarray, np.ndarray]:
        ts, vs = [], []
        for k, pair in self._pairs.items():
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
            g_time=global_sample_time(prev[1], cur[1], self.timing.readout, h),
            g_value=initial_velocity(gm.vector, dt),
            g_ok=bool(gm),
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
            v = refined_velocity(lm.motion, dt, rho, h)
            s1_t = cur[1] + rho * sel[:, 1] / h
            s2_t = prev[1] + rho * (sel[:, 1] - lm.motion[:, 1]) / h
            t_s, v_s = row_samples(lm, v, 0.5 * (s1_t + s2_t), b, cfg.min_blocks)
            if t_s.size < 2:
                break
            pair.local_t, pair.local_v = t_s, v_s

    def _emit(self, n: int, start: float, height: int) -> FrameMotion:
        times = self.timing.row_times(height, start)
        vel = self._velocity(times)
        ok = any(p.g_ok for k, p in self._pairs.items() if k in (n, n + 1))
        note = "" if ok else "no global motion found near this frame; velocity bridged"
        # No velocity beyond what the global search could have measured: the local
        # samples diverged; the global motion alone (Sec. V.B) is used for this frame.
        limit = float(self.config.global_motion.search)
        if not np.isfinite(vel).all() or np.abs(vel).max() > limit:
            t, v = self._samples(local=False)
            vel = scanline_velocity(t, v, times)
            note = "; ".join(x for x in (note, "local samples diverged: the global motion "
                                         "alone used") if x)
        disp = scanline_displacement(vel, self.timing)
        return FrameMotion(n, start, disp, vel, ok=ok, note=note)

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
