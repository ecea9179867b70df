"""Beyond the paper: dense per-pixel motion with a scanline-resolution camera trajectory.

The paper models one translation per scanline, smoothed by a Bezier curve through one
sample per frame: it cannot follow vibration (jello), hand shake, parallax or moving
objects (its Sec. VII). This method keeps the paper's rolling-shutter timing and
replaces the motion model:

1. **Dense correspondences.** DIS optical flow (OpenCV) from each frame to the previous
   one, and its inverse the other way; a forward-backward consistency check marks
   unreliable pixels (flow that folds, content leaving the frame).
2. **Camera trajectory at scanline resolution.** Row ``y`` of frame ``k`` is imaged at
   ``t = t_k + rho y / h`` and its content was at row ``y + f_y`` of frame ``k - 1``,
   imaged at ``t' = t_{k-1} + rho (y + f_y) / h`` (the paper's eq. 10 with readout
   ``rho``: two corresponding points are ``dt + rho (y - y') / h`` apart in time). The
   robust (median) flow of each row gives one equation ``c(t) - c(t') = -f`` on the
   camera's image-plane trajectory ``c``, sampled on a fine time grid (``grid`` samples
   per readout, linear in between). All rows of the frames around ``n`` are solved
   together by regularised least squares (a small penalty on the second difference of
   ``c`` selects the smoothest trajectory among those the data allow). Because every
   row contributes its own equation, motion that changes within a frame -- hand shake,
   23-40 Hz drone vibration -- is followed, not smoothed away; only components exactly
   periodic with the frame interval are invisible to frame differences, and the
   regulariser keeps those small. Rows far off the rest (a near pole the flow followed
   across flat sky) are weighed down and the path solved again
   (:func:`~unjello.motion.dense.camera.solve_reweighted`).
3. **Per-pixel residual.** What the camera trajectory does not explain (parallax,
   independently moving objects) is the residual flow of each pixel; where both
   neighbours exist its position over time is the quadratic through the three frames
   (residual 0 at the pixel's own time), else a straight line. Where the flow fails the
   check on both sides, the pixel falls back to the camera trajectory alone, and the
   fraction of such pixels is reported in the frame's ``note``.

Each pixel ``s`` then belongs at ``p = s - D(s)`` with
``D(s) = c(t_s) - c(t_ref) - R_s(t_ref)`` (eq. 26 per pixel), applied by the dense
backward warp (:func:`unjello.warp.maps.field_maps`, :func:`unjello.warp.warper.apply_maps`). No
still first frame is assumed: every frame is corrected to its own reference time.
"""

from __future__ import annotations

import dataclasses
import functools
from collections import deque
from collections.abc import Callable, MutableMapping
from concurrent.futures import Executor, Future

import cv2
import numpy as np

from ..._kernels.field import lands_inside
from ..._kernels.pixelwise import residual_side
from ...timing import SensorTiming
from ...trajectory import Diagnostics, FrameMotion
from ..flow.dis import (
    LARGE_MOTION,
    ROW_AGREE,
    FlowSettings,
    flow_pair,
    median_along,
    optical_flow,
    row_flows,
    textured,
)
from ..objects.rigid import PathTrack
from .camera import CameraSolution, solve_camera_trajectory, solve_reweighted
from .choice import ModelChoice
from .config import DenseConfig
from .field import (
    advected_velocity,
    at_reference,
    fill_unreliable,
    rows_minus,
    scale_axes,
    smooth_field,
    snap_to_camera,
    snap_to_global,
)
from .safety import FOLD_WARNING, DenseFrame, SafeField
from .vibration import (
    PROBE_CONTRAST,
    PROBE_TEXTURE,
    PROBE_WAIT,
    VIBRATION,
    probe_pair,
)

__all__ = ["DenseConfig", "DenseMethod", "FOLD_WARNING"]

#: A pair whose flow's translation strays from the pace of the pair before by more than this share
#: of it is measured again from that pace (:meth:`DenseMethod._steady`). (``docs/tuning.md#stray``)
STRAY = 0.15
#: Fixed-point steps of a row's flow by the camera model (:meth:`DenseMethod._row_model`).
#: (``docs/tuning.md#row_steps``)
ROW_STEPS = 7


def _row_flow(cur: np.ndarray, prev: np.ndarray, preset: str, max_width: int,
              finest_scale: int | None, expect: np.ndarray | None = None
              ) -> tuple[np.ndarray, np.ndarray]:
    """Return the flow from ``cur`` to ``prev`` and where it lands inside (rows-only mode)."""
    flow = optical_flow(cur, prev, preset, max_width, finest_scale, expect=expect)
    return flow, lands_inside(flow)


def _translation(flow: np.ndarray, ok: np.ndarray) -> np.ndarray:
    """Return the median ``(dx, dy)`` of a flow on its reliable pixels (all, if under 10 %).

    On every fourth pixel each way: a median of the whole working grid costs ms a pair.
    """
    sub, good = flow[::4, ::4].reshape(-1, 2), ok[::4, ::4].ravel()
    if good.mean() >= 0.1:
        sub = sub[good]
    return median_along(sub, 0).astype(np.float64)


@dataclasses.dataclass(frozen=True)
class _CameraRows:
    """A frame's camera motion per row of its working copy (times from the frame's start)."""

    grid_t: np.ndarray
    t_rows: np.ndarray
    t_ref: float
    path: PathTrack
    c_at: Callable[[np.ndarray], np.ndarray]
    cam_rows: np.ndarray  # the path at each row's time
    cam_disp: np.ndarray  # ... less the path at the reference time
    velocity: np.ndarray  # the path's velocity plus the row velocity's
    u_rows: np.ndarray  # the row velocity (per frame interval)
    whole: np.ndarray  # eq. 26 per scanline: the displacement with the row velocity's
    scale: np.ndarray  # full-frame pixels per working-copy pixel (x, y)
    rows_full: np.ndarray  # each full-frame row's position in the working copy

    def full(self, values: np.ndarray) -> np.ndarray:
        """Per-row ``values`` (working copy) at every full-frame row, in its pixels."""
        h = self.t_rows.shape[0]
        return np.stack([np.interp(self.rows_full, np.arange(h), values[:, k])
                         for k in range(2)], axis=1) * self.scale


class DenseMethod(SafeField, ModelChoice):
    """Streaming dense method: returns each frame's motion ``window`` frames later.

    Parameters
    ----------
    timing : SensorTiming
        Readout and reference (frames already in top-bottom orientation).
    config : DenseConfig
        Settings.
    flows : mutable mapping, optional
        Flows between frame pairs, kept across methods correcting the same frames.
    executor : concurrent.futures.Executor, optional
        Measures the flows of the next frame pairs while the motion of earlier frames is
        solved (threads: OpenCV releases the GIL). The motion is the same as without.
    ahead : int
        Frame pairs measured ahead on the executor (one per worker keeps them all busy);
        each frame's motion comes out that many frames later.
    """

    def __init__(self, timing: SensorTiming, config: DenseConfig = DenseConfig(),
                 flows: MutableMapping[tuple, tuple] | None = None,
                 executor: Executor | None = None, ahead: int = 2) -> None:
        self.timing = timing
        self.config = config
        self._flows = flows  # flows do not depend on the readout: kept by the caller
        self._frames: deque[DenseFrame] = deque()
        self._equations: deque[tuple[int, tuple]] = deque()  # (frame, its pair's rows)
        if config.vibration == "on":
            self.config = config.vibrating()
        self._auto, self._base = config.vibration == "auto", config
        self._decided = not self._auto
        #: The camera model from a frame on, and the evidence: ``(frame, model, choice)``.
        self.decisions: list[tuple[int, str, dict[str, float]]] = []
        self._halves: list[tuple] = []  # probed pairs: their starts, left and right rows
        self._note = ""  # added to every frame's note once vibration is detected
        #: The wobble (share of the height) for which vibration was detected, else None.
        self.wobble: float | None = None
        #: The evidence that chose the camera model (:func:`choose_model`).
        self.choice: dict[str, float] = {}
        self._freqs: tuple[tuple[int, int], np.ndarray] | None = None  # (window, freqs)
        self._final = False  # the clip has ended: its last frames' windows stand still
        self._count = 0  # frames pushed
        self._measured = 0  # frames whose flow to the previous frame is taken
        self._pending: deque[tuple[DenseFrame, DenseFrame, Future | tuple]] = deque()
        self._executor = executor
        self._ahead = 0 if executor is None else max(1, ahead)
        self._next_out = 0
        self._full: tuple[int, int] = (0, 0)
        # The last frame's spinning objects: (centre at its reference time, omega, that time)
        self._spins: list[tuple[np.ndarray, float, float]] = []
        # The last frame's objects kept whole (bool, working grid), or None.
        self._kept: np.ndarray | None = None
        # Once an object spun or was kept whole, the flows that follow are full detail.
        self._fine = False

    def push(self, frame: np.ndarray, start: float) -> list[FrameMotion]:
        """Add the next frame (grey, 0-255, top-bottom) starting at time ``start``."""
        img = np.asarray(frame)
        if img.dtype not in (np.uint8, np.float32):
            img = img.astype(np.float32)
        self._full = (img.shape[0], img.shape[1])
        ww = self.config.work_width
        if ww and img.shape[1] > ww:
            size = (ww, max(8, round(img.shape[0] * ww / img.shape[1])))
            img = cv2.resize(img, size, interpolation=cv2.INTER_AREA)
        cur = DenseFrame(self._count, float(start), img.astype(np.float32))
        self._count += 1
        if self._frames:
            self._pending.append((self._frames[-1], cur, self._measure(self._frames[-1], cur)))
        else:
            self._measured = max(self._measured, cur.index + 1)  # nothing to measure
        self._frames.append(cur)
        return self._advance(keep=self._ahead, final=False)

    @property
    def vibrating(self) -> bool | None:
        """Whether the vibration settings are in use; None while ``auto`` has not decided."""
        return self.config.window == VIBRATION["window"] if self._decided else None

    def flush(self) -> list[FrameMotion]:
        """Return the motion of the frames still pending at the end of the clip."""
        return self._advance(keep=0, final=True)

    def _advance(self, keep: int, final: bool) -> list[FrameMotion]:
        """Take the measured pairs one at a time, each followed by what it makes ready.

        The camera model's choice and the frames emitted with it then follow from the
        pairs alone, not from how many flows an executor had finished when asked: taken
        several at once, the choice saw 9 pairs instead of 8 and a real clip came out
        differently under load.
        """
        out: list[FrameMotion] = []
        while self._take_flows(keep):
            out += self._ready(final=False)
        return out + self._ready(final)

    def _measure(self, prev: DenseFrame, cur: DenseFrame) -> Future | tuple:
        """Start (on the executor, if any) or look up the flows between two frames."""
        args: tuple
        if not self.config.per_pixel:  # rows only: one flow, its row summary rejects outliers
            args = (cur.image, prev.image, self.config.flow_preset, 0, self.config.finest_scale)
            job: Callable[..., tuple] = _row_flow
        else:
            cur.settings = self._flow_settings
            key = self._flow_key(prev, cur)
            if self._flows is not None and key in self._flows:
                return self._flows[key]
            # The first pair has no pace to start from (:meth:`_steady`): where content
            # enters, flows nothing confirms are not kept.
            args = (prev.image, cur.image, cur.settings)
            job = functools.partial(flow_pair, entering=prev.index == 0)
        return self._executor.submit(job, *args) if self._executor is not None else job(*args)

    @property
    def _flow_settings(self) -> FlowSettings:
        """Return the flow's settings: full detail for good once an object spun or was kept.

        The polished flow (``detail='polished'``) is smooth enough to pass a spinning
        wheel's flow as consistent, which then went uncorrected (the simulated wheel
        0.13x -> 0.29x; ``docs/history/measurements.md``): once a frame had an object spinning or
        kept whole, the flows that follow are the full ones. (A vibrating clip's are
        too: :data:`~unjello.motion.dense.vibration.VIBRATION` sets them.)
        """
        if not self._fine:
            return self.config.flow
        return dataclasses.replace(self.config, detail="full").flow

    def _take_flows(self, keep: int) -> bool:
        """Take the next pair's flows, if more than ``keep`` are pending or they are done.

        Each pair's row equations are formed as its flows arrive, in the order of the
        frames, so the motion is the same whether the flows were computed ahead on an
        executor or here, one after another. Returns whether a pair was taken.
        """
        if self._pending:
            prev, cur, job = self._pending[0]
            fresh = isinstance(job, Future)
            if isinstance(job, Future):  # (as ``fresh``, for the type checker)
                if len(self._pending) <= keep and not job.done():
                    return False
                job = job.result()
            self._pending.popleft()
            if self.config.per_pixel and self._fine and cur.settings != self._flow_settings:
                # Started before an object spun: again in full, however far ahead it began.
                cur.settings = self._flow_settings
                job, fresh = flow_pair(prev.image, cur.image, cur.settings,
                                       entering=prev.index == 0), True
            job = self._steady(prev, cur, job)
            if self.config.per_pixel:
                if fresh:
                    self._keep_flows(prev, cur, job)
                cur.bwd, cur.bwd_ok, prev.fwd, prev.fwd_ok = job
            else:
                cur.bwd, cur.bwd_ok = job
            self._equations.append((cur.index, self._row_equations(prev, cur)))
            if self._auto and min(prev.contrast, cur.contrast) >= PROBE_CONTRAST:
                # Rows of each half, for the vibration test (frames too flat to give
                # flow, as in a fade from black, would wobble with their noise), of
                # two-dimensional texture only (:func:`textured`).
                self._halves.append(probe_pair(prev.start, cur.start, cur.bwd,
                                               cur.bwd_ok & textured(cur.image, PROBE_TEXTURE)))
            if not self.config.per_pixel:
                cur.bwd = cur.bwd_ok = None  # nothing per pixel is needed later
            self._measured = cur.index + 1
            return True
        return False

    def _steady(self, prev: DenseFrame, cur: DenseFrame, job: tuple) -> tuple:
        """Return a pair's flows, measured again from the last pair's pace if they lost it.

        A camera keeps its pace from one frame to the next. Where the pair before moved
        fast (:data:`~unjello.motion.flow.dis.LARGE_MOTION`) and this pair's flow (its median
        translation) strays from that pace by more than :data:`STRAY` of it, the flow is
        measured again starting from the pace too (:func:`~unjello.motion.flow.dis.flow_pair`'s
        ``expect``), which is used where it matches the pair better: over a flat sky with
        a pole, the phase correlation and DIS lost a pan of 40 % of the width a frame that
        the pairs on either side followed; with the pole nearer, DIS followed the pole,
        all that the two frames shared (``docs/history/measurements.md``).
        """
        dt = cur.start - prev.start
        if dt <= 0:
            return job
        shift = _translation(job[0], job[1])
        if prev.pace is not None:
            expect = prev.pace * dt
            size = float(np.hypot(*expect))
            if (size >= LARGE_MOTION * cur.image.shape[1]
                    and float(np.hypot(*(shift - expect))) > STRAY * size):
                c = self.config
                job = (flow_pair(prev.image, cur.image, cur.settings, expect=expect)
                       if c.per_pixel and cur.settings is not None else
                       _row_flow(cur.image, prev.image, c.flow_preset, 0, c.finest_scale,
                                 expect))
                shift = _translation(job[0], job[1])
        cur.pace = shift / dt
        return job

    def _keep_flows(self, prev: DenseFrame, cur: DenseFrame, job: tuple) -> None:
        """Keep a pair's measured flows for the caller's other methods (if it keeps them)."""
        if self._flows is not None:
            self._flows[self._flow_key(prev, cur)] = job

    def _flow_key(self, prev: DenseFrame, cur: DenseFrame) -> tuple:
        """Return the key a pair's measured flows are kept under for the caller's other methods."""
        return (prev.start, cur.start, cur.image.shape, self.timing.direction, cur.settings,
                prev.index == 0)

    def _row_equations(self, prev: DenseFrame, cur: DenseFrame) -> tuple:
        """Row flows of ``cur`` -> equations ``c(t_a) - c(t_b) + u(y)(t_a - t_b) = delta``."""
        assert cur.bwd is not None and cur.bwd_ok is not None
        h = cur.image.shape[0]
        rho = self.timing.readout
        y, med, wgt = row_flows(cur.bwd, cur.bwd_ok, ROW_AGREE)
        t_a = cur.start + rho * y / h
        t_b = prev.start + rho * (y + med[:, 1]) / h
        return t_a, t_b, y / max(h - 1, 1), -med, wgt

    def _pairs(self, n: int, final: bool) -> tuple[int, int]:
        """First and last pair (by later frame) of frame ``n``'s window.

        ``history`` pairs before and ``window`` after; near the ends of the clip the window
        keeps its length and shifts inwards, so the first and last frames are solved with
        as much context as the others.
        """
        span = self.config.history + self.config.window
        lo = max(1, n - self.config.history + 1)
        hi = lo + span - 1
        if final:
            hi = min(hi, self._measured - 1)
            lo = max(1, hi - span + 1)
        return lo, hi

    def _ready(self, final: bool) -> list[FrameMotion]:
        out: list[FrameMotion] = []
        self._final = final
        if not self._decided:
            probed = len(self._halves) >= self.config.probe
            if not final and not probed and self._measured - 1 < PROBE_WAIT * self.config.probe:
                return out
            self._decide()
        elif self._auto and not self.vibrating and len(self._halves) >= self.config.probe:
            self._decide()  # again, on the pairs since: a drone that takes off
        while self._next_out < self._measured and (
                final or self._measured - 1 >= self._pairs(self._next_out, False)[1]):
            n = self._next_out
            fr = next(f for f in self._frames if f.index == n)
            out.append(self._emit(fr, self._pairs(n, final)))
            self._next_out += 1
            while self._frames and self._frames[0].index < n:  # n - 1 stays for n + 1
                self._frames.popleft()
            span = self._kept_pairs()
            while (len(self._equations) > span
                   and self._equations[0][0] < self._pairs(n + 1, False)[0]):
                self._equations.popleft()
        return out

    def _camera(self, pairs: tuple[int, int]) -> CameraSolution | None:
        eqs = [rows for index, rows in self._equations
               if pairs[0] <= index <= pairs[1] and len(rows[0])]
        if not eqs:
            return None
        t_a, t_b, rows, delta, wgt = (np.concatenate([e[i] for e in eqs]) for i in range(5))
        # At least 1/256 of a frame: the solve's band is 1 / step wide, its cost the
        # square of that (a readout of 0.05 took 0.57 s a frame; docs/tuning.md).
        step = max(self.timing.readout / self.config.grid, 1.0 / 256)
        smoothness = self.config.smoothness
        if len(eqs) == 1:
            smoothness = max(smoothness, self.config.pair_smoothness)
        if not self.config.sinusoids or len(eqs) < 3:
            # Rows that followed a near object (the only content over a flat sky) are
            # outvoted by the pairs around them (a lone pair has no others to do it).
            solve = solve_reweighted if len(eqs) > 1 else solve_camera_trajectory
            return solve(t_a, t_b, rows, delta, wgt, step, smoothness)
        return solve_camera_trajectory(t_a, t_b, rows, delta, wgt, step, smoothness,
                                       freqs=self._frequencies(pairs, t_a, t_b, delta, wgt))

    def _emit(self, fr: DenseFrame, pairs: tuple[int, int]) -> FrameMotion:
        """Frame ``fr``'s motion, stage by stage (the package's docstring lists them)."""
        cam = self._camera(pairs)  # the camera trajectory over the window
        if cam is None:
            z = np.zeros((self._full[0], 2))
            return FrameMotion(fr.index, fr.start, z, z, ok=False,
                               note="no reliable motion: frame left as is",
                               events=("no-motion",))
        rows = self._camera_rows(fr, cam)  # eq. 26 per scanline
        if not self.config.per_pixel:
            return FrameMotion(fr.index, fr.start, rows.full(rows.whole),
                               rows.full(rows.velocity), ok=True, note=self._note)
        # Each pixel's motion beyond the camera's: the per-pixel residual.
        field_resid, fallback, entering = self._residual(
            fr, rows.t_rows, rows.t_ref, rows.cam_rows, rows.cam_disp,
            (float(rows.grid_t[0]), float(cam.step), cam.c), rows.u_rows)
        frac, new = float(fallback.mean()), float(entering.mean())
        note = (f"{100 * frac:.0f}% of pixels on the camera model ({100 * new:.0f}% entering "
                "the frame, the rest unreliable flow)") if frac > 0.05 else ""
        # Do no harm: no fold or tear it can avoid, objects fitted a motion of their own. A
        # region kept whole falls back on its rows' whole camera motion: a steady pan
        # splits it between the trajectory and the rows' velocity.
        field, folds, kept, spun, said, fronts, events = self._safe_field(
            fr, rows_minus(rows.cam_disp, field_resid), rows.whole, fallback, entering,
            float(rows.t_ref), rows.path, rows.u_rows.mean(axis=0))
        self._fine = self._fine or kept > 0 or spun > 0
        note = "; ".join(n for n in (self._note, note, said) if n)
        # Back to the full frame: per-row values per full row, field in full-frame pixels.
        disp = rows.full(median_along(field[:, ::4], 1))  # a summary: every 4th is plenty
        scale_axes(field, *rows.scale)
        for layer in fronts:  # their displacements too; the weight stays
            layer[..., :2] *= rows.scale
        # What the frame's neighbours saw beyond its edge: their flows, for the warp's fill.
        neighbours = self._fill_flows(fr, rows.t_rows, rows.c_at, rows.u_rows)
        return FrameMotion(fr.index, fr.start, disp, rows.full(rows.velocity), ok=True,
                           note=note, diagnostics=Diagnostics(frac, new, kept, folds, spun),
                           field=field, front=fronts, neighbours=neighbours,
                           camera=rows.full(rows.whole), events=events)

    def _camera_rows(self, fr: DenseFrame, cam: CameraSolution) -> _CameraRows:
        """Return the camera's motion at each row of ``fr`` (working copy), from its path."""
        h, w = fr.image.shape
        # Times relative to the frame's start, so float32 keeps sub-row precision.
        grid_t = cam.t0 - fr.start + cam.step * np.arange(cam.c.shape[0])
        t_rows = self.timing.row_times(h, fr.start) - fr.start
        t_ref = self.timing.reference_time(h, fr.start) - fr.start
        path = PathTrack(grid_t, cam.c)  # the camera's path (float32), and a rigid fit's track

        def c_at(t: np.ndarray) -> np.ndarray:
            return path(t).astype(np.float32)

        cam_rows = c_at(t_rows)
        cam_disp = cam_rows - c_at(np.array([t_ref]))[0]
        velocity = np.gradient(cam_rows.astype(np.float64), t_rows, axis=0) if h > 1 else (
            np.zeros((h, 2)))
        u_rows = np.zeros((h, 2))
        if cam.u.shape[0]:
            knots = np.linspace(0, 1, cam.u.shape[0])
            frac_rows = np.arange(h) / max(h - 1, 1)
            u_rows = np.stack([np.interp(frac_rows, knots, cam.u[:, k]) for k in range(2)],
                              axis=1)
        full_h, full_w = self._full
        return _CameraRows(grid_t, t_rows, t_ref, path, c_at, cam_rows, cam_disp,
                           velocity + u_rows, u_rows,
                           # Eq. 26 per scanline: the camera's displacement plus the row
                           # velocity's.
                           cam_disp + u_rows * (t_rows - t_ref)[:, None],
                           np.array([full_w / w, full_h / h], dtype=np.float32),
                           (np.arange(full_h) + 0.5) * h / full_h - 0.5)

    def _fill_flows(self, fr: DenseFrame, t_rows: np.ndarray,
                    c_at: Callable[[np.ndarray], np.ndarray], u_rows: np.ndarray
                    ) -> tuple[tuple[int, np.ndarray], ...]:
        """Return the flows to the neighbours that the warper follows for what it did not see.

        The strip beyond the edge is taken from a neighbour along the flow of the pixels
        nearest the edge, and background a near object uncovered along the flow beside it
        (:mod:`unjello.warp.fill.neighbours`); a failed flow there (a near pole the flow lost,
        content entering the frame) carried it to an arbitrary place. Failed pixels are
        filled as the residuals are (:func:`~unjello.motion.dense.field.fill_unreliable`): the
        reliable flow near them, or where none is near their row's camera model (the
        trajectory's motion over the frame interval plus the row velocity's). The camera
        model alone cost the Carla pairs 0.2 dB (forward motion, which a row model cannot
        give).
        """
        near = {f.index: f for f in self._frames}
        out = []
        for offset, flow, ok in ((-1, fr.bwd, fr.bwd_ok), (1, fr.fwd, fr.fwd_ok)):
            if flow is None:
                continue
            other = near.get(fr.index + offset)
            if ok is not None and other is not None and not ok.all():
                model = self._row_model(t_rows, other.start - fr.start, c_at, u_rows)
                flow = fill_unreliable(flow, ok, self.config.fill_sigma, prior=model[:, None])
            out.append((offset, flow))
        return tuple(out)

    @staticmethod
    def _row_model(t_rows: np.ndarray, dt: float, c_at: Callable[[np.ndarray], np.ndarray],
                   u_rows: np.ndarray) -> np.ndarray:
        """Each row's flow to the frame ``dt`` away by the camera model alone (h, 2).

        A row's content lies in that frame on the row the model carries it to, read at
        that row's time there (eq. 10's timing): in a tilt, ``1 / (1 - v_y t_row)`` times
        what the same row would read (the astronaut's diagonal 25 %/1.0 pair, 48 px a
        frame down: 65.5 px against 48). Solved by :data:`ROW_STEPS` fixed-point steps.
        """
        per_row = np.gradient(t_rows) if len(t_rows) > 1 else np.zeros(len(t_rows))
        t = t_rows + dt
        for _ in range(ROW_STEPS):
            model = c_at(t) - c_at(t_rows) + u_rows * (t - t_rows)[:, None]
            t = t_rows + dt + per_row * model[:, 1]
        return model.astype(np.float32)

    def _residual(self, fr: DenseFrame, t_rows: np.ndarray, t_ref: float, cam_rows: np.ndarray,
                  cam_disp: np.ndarray, cam: tuple[float, float, np.ndarray],
                  u_rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Each pixel's motion beyond the camera trajectory's, carried to the reference time.

        A pixel with no reliable flow takes its reliable neighbours' (Gaussian average);
        with none near, the row velocity's ``u_rows`` (per frame interval), so that it
        moves with its row's camera model: a frame pair, or a steady pan, cannot tell the
        trajectory from the row velocity, and content entering the frame at its side took
        the trajectory's part alone (a 40 % pan: 0.41x its row's displacement).

        Returns
        -------
        field_resid : ndarray of shape (h, w, 2)
            Quadratic through the residual flows to both neighbours. With one neighbour
            (the ends of a clip, a frame pair) the pixel's mean velocity over its measured
            way, moved along its way to the reference time through the smooth part of the
            flow field (:func:`~unjello.motion.dense.field.advected_velocity`; with ``advect``
            off, the straight line through the one residual). Unreliable pixels take their reliable
            neighbours' (Gaussian average), then a 5x5 median.
        fallback : ndarray of bool, shape (h, w)
            Pixels whose flow was unreliable on both sides.
        entering : ndarray of bool, shape (h, w)
            Those of them that no neighbour saw: content entering the frame (their flow
            lands outside it on every side), which no flow can match.
        """
        h, w = fr.image.shape
        rho = self.timing.readout
        t_s = t_rows.astype(np.float32)[:, None]  # one time a row
        grid_t0, step, c = cam
        c_grid = np.ascontiguousarray(c, np.float32)
        t_own = np.ascontiguousarray(t_rows, np.float32)
        c_own = np.ascontiguousarray(cam_rows, np.float32)
        sides = []
        entering = np.ones((h, w), dtype=bool)  # no neighbour's flow lands inside
        neighbours = {f.index: f for f in self._frames}
        for flow, ok, other in ((fr.bwd, fr.bwd_ok, neighbours.get(fr.index - 1)),
                                (fr.fwd, fr.fwd_ok, neighbours.get(fr.index + 1))):
            if flow is None or ok is None or other is None:
                continue
            entering &= ~lands_inside(flow)
            if self.config.snap_window:
                flow = snap_to_global(fr.image, other.image, flow, ok, self.config.snap_window)
            # The camera's part of the flow (eq. 26) off it, and the time to where it lands.
            e, resid = residual_side(np.ascontiguousarray(flow, np.float32), c_grid, grid_t0,
                                     step, other.start - fr.start, rho / h, t_own, c_own)
            if self.vibrating:  # rows bent by a vibration: the trajectory follows them
                resid = snap_to_camera(fr.image, other.image, flow, resid)
            sides.append((e, resid, ok, flow))
        # Per row: the time from each pixel's to the reference.
        ahead_t = np.float32(t_ref) - t_s
        u = np.ascontiguousarray(u_rows[:, None, :], np.float32)
        if len(sides) == 1 and self.config.advect:
            # One neighbour: the pixel's velocity, carried along its way to t_ref.
            e, r, ok, flow = sides[0]
            vel = smooth_field(fill_unreliable(r / e[..., None], ok, self.config.fill_sigma,
                                               prior=u))
            dt = ahead_t[..., None]
            ahead = dt * vel - cam_disp[:, None, :]
            return dt * advected_velocity(vel, ok, flow, ahead), ~ok, entering
        field_resid, fallback = at_reference([(e, r, ok) for e, r, ok, _ in sides], ahead_t)
        along = ahead_t[..., None] * u  # the row velocity's part, to the reference time
        field_resid = smooth_field(fill_unreliable(field_resid, ~fallback,
                                                     self.config.fill_sigma, prior=along))
        return field_resid, fallback, entering & fallback
