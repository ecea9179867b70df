"""Beyond the paper: rolling-shutter correction from a gyroscope log.

A camera that shakes mostly *rotates*; a gyroscope measures that rotation at hundreds of
samples a second, far finer than one sample per frame, so the orientation at the time
of every scanline is known (the approach of Karpenko et al. 2011 and Gyroflow). Row
``y`` of frame ``k`` is read at ``t_y = t_k + rho T y / h`` (the paper's eq. 10 with
readout ``rho`` of the frame interval ``T``); a pixel ``s`` of that row, seen at the
reference time ``t_ref`` of its frame, lies at

    p = K R(phi) K^-1 s,   phi = M (Theta(t_ref) - Theta(t_y)),

with ``Theta`` the integral of the angular rate (first order in the small rotation
within a frame), ``M`` the mapping from the gyro's axes to the camera's and ``K`` the
pinhole intrinsics (focal ``f``, centre of the frame). The per-pixel displacement
``s - p`` is what the dense warp applies (:func:`unjello.warp.maps.field_maps`): one
homography per scanline, which handles roll and the keystone of pitch and yaw, not
only the translation of the paper's model. Through a fisheye lens
(``GyroConfig.distortion``) the rotation acts on the undistorted rays,
``p = distort(R undistort(s))``. Camera translation (parallax) is not modelled.

What a log rarely states -- the offset between its clock and the video's, the axes, the
focal length -- is found from the footage (:func:`calibrate`): DIS optical flow of the
first frames gives each row's motion, which the gyro must predict. A coarse search over
the whole log matches eight rows of every frame pair (``dx ~ f b``, ``dy ~ -f a`` for the
camera-axis rotation ``(a, b, c)`` between the row's times in the two frames, for every
signed choice of gyro axes), then a fine search within a frame interval matches every
row, roll (``dx ~ -c (y - c_y)``) included.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from ..._kernels.field import lands_inside
from ...errors import InputError, SettingsError
from ...gyrolog import GyroConfig, GyroLog, _axes_spec, axes_matrix
from ...lens import Lens
from ...timing import SensorTiming
from ...trajectory import FIELD_STEP, FrameMotion
from ..flow.dis import optical_flow, row_flows

__all__ = ["GyroCalibration", "GyroMethod", "GyroMismatch", "calibrate", "gyro_field"]

# Flow for the calibration is computed on copies at most this wide (DIS medium at its
# full resolution there).
_SYNC_WIDTH = 320
# A log is refused when it explains less than this share of the measured row motion: its
# own log explains all of a simulated shake, a real phone clip's 0.61, random ones less
# (``docs/tuning.md``).
_AGREEMENT = 0.3


class GyroMismatch(InputError):
    """The gyro does not explain the footage's motion.

    Attributes
    ----------
    agreement : float
        The largest share of the measured row motion any calibration explains (0 when
        none is plausible).
    """

    def __init__(self, message: str, agreement: float) -> None:
        super().__init__(message)
        self.agreement = agreement

    @property
    def summary(self) -> str:
        """The finding in a few words (for a fallback's note)."""
        if self.agreement <= 0:
            return ("no clock offset, axes and plausible focal length make the gyro "
                    "explain the picture's row motion")
        return (f"the gyro explains at most {100 * self.agreement:.0f}% of the picture's "
                f"row motion ({100 * _AGREEMENT:.0f}% needed)")


@dataclass(frozen=True)
class GyroCalibration:
    """How a gyro log maps to a clip.

    Parameters
    ----------
    axes : ndarray of shape (3, 3)
        Camera-from-gyro axis mapping (:func:`axes_matrix`).
    offset : float
        Log time of the first frame's first scanline, seconds.
    focal : float
        Focal length, pixels of the full frame.
    agreement : float
        Share of the measured row motion the gyro explains (1: all; NaN: not measured).
    distortion : tuple of 4 float, optional
        Fisheye ``k1 .. k4`` (:class:`GyroConfig`); None: a pinhole.
    """

    axes: np.ndarray
    offset: float
    focal: float
    agreement: float = float("nan")
    distortion: tuple[float, float, float, float] | None = None

    def describe(self) -> str:
        """One line: axes, offset, focal length and agreement."""
        ms = round(1000 * self.offset, 1) + 0.0  # no "-0.0"
        text = (f"gyro axes {_axes_spec(self.axes)}, offset {ms:.1f} ms, "
                f"focal {self.focal:.0f} px")
        if self.distortion is not None:
            text += ", fisheye lens k " + ", ".join(f"{v:.3g}" for v in self.distortion)
        if np.isfinite(self.agreement):
            text += f", explains {100 * self.agreement:.0f}% of the row motion"
        return text


@dataclass(frozen=True)
class _Rows:
    """Measured row flows of frame pairs, in full-frame pixels."""

    pair: np.ndarray      # (m,) index k of the later frame of the pair
    row: np.ndarray       # (m,) row y in frame k
    flow: np.ndarray      # (m, 2) where the row's content is in frame k - 1, minus (x, y)
    weight: np.ndarray    # (m,)

    @classmethod
    def stack(cls, pairs: Sequence[tuple[int, np.ndarray, np.ndarray, np.ndarray]]) -> _Rows:
        """Join ``(k, rows, flows, weights)`` of several pairs."""
        return cls(pair=np.concatenate([np.full(r[1].size, r[0]) for r in pairs]),
                   row=np.concatenate([r[1] for r in pairs]),
                   flow=np.concatenate([r[2] for r in pairs]),
                   weight=np.concatenate([r[3] for r in pairs]))


def _candidate_axes() -> list[np.ndarray]:
    """All 48 signed permutations of the three axes."""
    out = []
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            m = np.zeros((3, 3))
            m[np.arange(3), perm] = signs
            out.append(m)
    return out


def _row_model(theta_a: np.ndarray, theta_b: np.ndarray, axes: np.ndarray, y: np.ndarray,
               cy: float, focal: float) -> tuple[np.ndarray, np.ndarray]:
    """Linearised shift of the centre of rows from time a to time b: (f-part, rest).

    With the camera rotation ``(a, b, c) = M (Theta_b - Theta_a)``, a point of row ``y``
    at the centre column moves by ``f (b, -a (1 + r^2)) + (-c (y - c_y), 0)`` with
    ``r = (y - c_y) / f`` (first order in the rotation).
    """
    phi = (theta_b - theta_a) @ axes.T
    r2 = ((y - cy) / focal) ** 2
    g = np.stack([phi[:, 1], -phi[:, 0] * (1 + r2)], axis=-1)
    rest = np.stack([-phi[:, 2] * (y - cy), np.zeros_like(y)], axis=-1)
    return g, rest


def calibrate(rows: _Rows, starts: np.ndarray, log: GyroLog, timing: SensorTiming,
              frame_interval: float, size: tuple[int, int], config: GyroConfig
              ) -> GyroCalibration:
    """Find the log's time offset, axes and the focal length from measured row motion.

    Parameters
    ----------
    rows : _Rows
        Row flows of consecutive frame pairs (from :class:`GyroMethod`).
    starts : ndarray
        Start time of each frame, in frame intervals.
    log : GyroLog
        The gyro samples.
    timing : SensorTiming
        Readout (frames in top-bottom orientation).
    frame_interval : float
        Seconds per frame interval.
    size : (int, int)
        Frame height and width.
    config : GyroConfig
        What is given (``axes``, ``offset``, ``focal``) is kept.

    Returns
    -------
    GyroCalibration

    Raises
    ------
    GyroMismatch
        When the gyro does not explain the footage's motion (no offset, axes and focal
        length in a plausible range fit).
    InputError
        When the footage has too little texture or motion to calibrate against.
    """
    h, w = size
    if rows.row.size < 16:
        raise InputError("too little texture in the first frames to calibrate the gyro log; "
                         "give gyro_offset=, gyro_axes= and focal=")
    if np.sqrt(np.average(np.sum(rows.flow ** 2, axis=1), weights=rows.weight)) < 0.1:
        raise InputError("the footage hardly moves in its first frames: nothing to calibrate "
                         "the gyro log against; give gyro_offset=, gyro_axes= and focal=")
    cy = (h - 1) / 2.0
    T, rho = frame_interval, timing.readout
    axes_list = ([axes_matrix(config.axes)] if config.axes != "auto" else _candidate_axes())
    fmin, fmax = 0.13 * w, 12.0 * w  # horizontal fields of view of 150 to 5 degrees
    wgt = rows.weight
    t_a = (starts[rows.pair] + rho * rows.row / h) * T
    t_b = (starts[rows.pair - 1] + rho * (rows.row + rows.flow[:, 1]) / h) * T

    if config.offset is None:
        # Coarse: eight rows of every pair, each at its own time, against the rotation
        # between those times (linearised, no roll), every eighth of a frame interval over
        # the whole log, every signed choice of two axes; the focal length in closed form.
        pick = np.concatenate([np.flatnonzero(rows.pair == k)[
            np.linspace(0, np.sum(rows.pair == k) - 1, 8).astype(int)]
            for k in np.unique(rows.pair)])
        d, wp = rows.flow[pick], wgt[pick]
        ta, tb = t_a[pick], t_b[pick]
        lo, hi = log.time[0] - ta.min(), log.time[-1] - ta.max()
        if lo > hi:
            lo, hi = hi, lo
        offsets = np.arange(lo - T, hi + T, T / 8)
        gx, gy, ss = (np.empty((offsets.size, 3)) for _ in range(3))  # (offsets, axes)
        chunk = max(1, 2 ** 22 // pick.size)  # an hour's log: 900 000 offsets
        for c in range(0, offsets.size, chunk):
            o = offsets[c:c + chunk, None]
            inc = log.theta(tb[None] + o) - log.theta(ta[None] + o)
            gx[c:c + chunk] = np.einsum("oki,k->oi", inc, wp * d[:, 0])
            gy[c:c + chunk] = np.einsum("oki,k->oi", inc, wp * d[:, 1])
            ss[c:c + chunk] = np.einsum("oki,oki,k->oi", inc, inc, wp)
        energy = float(np.sum(wp[:, None] * d ** 2)) + 1e-12
        best: tuple[float, float, np.ndarray | None] = (-1.0, 0.0, None)
        for m in axes_list:
            ib, sb = int(np.argmax(np.abs(m[1]))), m[1].max() + m[1].min()
            ia, sa = int(np.argmax(np.abs(m[0]))), m[0].max() + m[0].min()
            num = sb * gx[:, ib] - sa * gy[:, ia]
            den = ss[:, ib] + ss[:, ia] + 1e-18
            focal_at = num / den
            score = np.where((focal_at > fmin) & (focal_at < fmax),
                             num ** 2 / (den * energy), 0.0)
            i = int(np.argmax(score))
            if score[i] > best[0]:
                best = (float(score[i]), float(offsets[i]), m)
        centre, fine = best[1], np.arange(-T, T + 1e-9, T / 64)
        if best[2] is not None:  # the roll axis is the third; its sign is left to the rows
            axes_list = [m for m in axes_list if np.array_equal(m[:2], best[2][:2])]
    else:
        centre, fine = config.offset, np.zeros(1)

    # Fine: every row at its own time, roll included; focal fitted by least squares.
    u_all = rows.flow
    energy = float(np.sum(wgt[:, None] * u_all ** 2)) + 1e-12
    result: tuple[float, np.ndarray, float, float] | None = None
    f0 = config.focal or float(w)
    for o in centre + fine:
        th_a, th_b = log.theta(t_a + o), log.theta(t_b + o)
        for m in axes_list:
            f = f0
            for _ in range(2):  # the keystone term depends (weakly) on f
                g, rest = _row_model(th_a, th_b, m, rows.row, cy, f)
                u = u_all - rest
                if config.focal is None:
                    gg = float(np.sum(wgt[:, None] * g * g))
                    f = float(np.sum(wgt[:, None] * u * g)) / gg if gg > 0 else 0.0
                    if not fmin < f < fmax:
                        break
            if not fmin < f < fmax:
                continue
            resid = float(np.sum(wgt[:, None] * (u - f * g) ** 2))
            agree = 1.0 - resid / energy
            if result is None or agree > result[3]:
                result = (float(o), m, f, agree)
    if result is None or result[3] < _AGREEMENT:
        share = f"at most {100 * max(result[3], 0.0):.0f}%" if result else "none"
        raise GyroMismatch(
            f"the gyro log does not explain the footage's motion ({share} of the row motion "
            f"in the first frames, at any clock offset, axes and plausible focal length; "
            f"{100 * _AGREEMENT:.0f}% needed). Check that the log belongs to this clip and "
            "its gyro_layout= and gyro_units=; a camera that hardly rotates (on a gimbal, "
            "its picture moving with the vehicle's travel) needs the dense method",
            max(result[3], 0.0) if result else 0.0)
    return GyroCalibration(axes=result[1], offset=result[0], focal=result[2],
                           agreement=result[3], distortion=config.distortion)


def _rotated(log: GyroLog, cal: GyroCalibration, size: tuple[int, int], t_from: np.ndarray,
             t_to: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Where pixels ``(x, row y)`` seen at ``t_from[row]`` are seen at ``t_to[row]``.

    One homography ``K R K^-1`` per row, ``R`` the rotation by ``M (Theta(t_to) -
    Theta(t_from))``; through a fisheye lens (``cal.distortion``) the rotation acts on the
    undistorted rays, ``distort(R undistort(p))``. Returns ``(len(y), len(x), 2)``.
    """
    from scipy.spatial.transform import Rotation  # here: an import the other methods skip


    lens = Lens(cal.focal, cal.distortion)
    k = lens.matrix(size)
    phi = (log.theta(t_to) - log.theta(t_from)) @ cal.axes.T
    rot = Rotation.from_rotvec(phi).as_matrix()  # (rows, 3, 3)
    pts = np.stack(np.broadcast_arrays(x[None, :], y[:, None], np.ones(1)), axis=-1)
    if cal.distortion is None:
        q = pts @ (k @ rot @ np.linalg.inv(k)).transpose(0, 2, 1)
        return q[..., :2] / q[..., 2:3]
    rays = lens.undistort(pts[..., :2], size)
    rays = np.concatenate([rays, np.ones((*pts.shape[:2], 1))], axis=-1)
    q = rays @ rot.transpose(0, 2, 1)
    q = q[..., :2] / np.maximum(q[..., 2:3], 1e-6)  # (a ray turned behind: far off anyway)
    return lens.distort(q, size)


def gyro_field(log: GyroLog, cal: GyroCalibration, timing: SensorTiming, start: float,
               frame_interval: float, size: tuple[int, int], step: int = FIELD_STEP
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[tuple[int, np.ndarray], ...]]:
    """Per-pixel displacement of one frame: a homography per scanline (module notes).

    Parameters
    ----------
    log : GyroLog
    cal : GyroCalibration
    timing : SensorTiming
        Readout and reference (top-bottom orientation).
    start : float
        The frame's first scanline time, frame intervals.
    frame_interval : float
        Seconds per frame interval.
    size : (int, int)
        Frame height and width.
    step : int
        Sampling of the field, pixels (a homography per row is smooth: the motion JSON's
        own sampling).

    Returns
    -------
    field : ndarray of shape (ceil(h / step), ceil(w / step), 2), float32
        ``s - p`` at the grid's pixel centres, in full-frame pixels.
    displacement : ndarray of shape (h, 2)
        ``s - p`` at the centre column of every scanline (eq. 26's per-scanline value).
    velocity : ndarray of shape (h, 2)
        Image velocity at the centre column, pixels per frame interval (first order).
    neighbours : tuple of (int, ndarray)
        Where each grid pixel is seen one frame earlier (-1) and later (1), as a flow in
        pixels of the grid (:attr:`unjello.trajectory.FrameMotion.neighbours`: the warp
        takes what the frame's own lines never saw from there). The rotation over one
        frame interval at the pixel's row time; the row it lands on is read a little
        earlier or later, a second-order effect.
    """
    h, w = size
    t0, T = cal.offset, frame_interval
    t_ref = np.array([t0 + timing.reference_time(h, start) * T])
    hf, wf = -(-h // step), -(-w // step)
    gy = (np.arange(hf) + 0.5) * h / hf - 0.5
    gx = (np.arange(wf) + 0.5) * w / wf - 0.5
    src = np.stack(np.meshgrid(gx, gy), axis=-1)
    t_grid = t0 + (start + timing.readout * gy / h) * T
    fld = (src - _rotated(log, cal, size, t_grid, t_ref, gx, gy)).astype(np.float32)
    to_grid = np.array([wf / w, hf / h])
    neighbours = tuple(
        (k, ((_rotated(log, cal, size, t_grid, t_grid + k * T, gx, gy) - src) * to_grid)
         .astype(np.float32)) for k in (-1, 1))
    ys = np.arange(h, dtype=np.float64)
    cx = np.array([(w - 1) / 2.0])
    t_rows = t0 + (start + timing.readout * ys / h) * T
    disp = np.stack([np.broadcast_to(cx, (h,)), ys], axis=-1) - _rotated(
        log, cal, size, t_rows, t_ref, cx, ys)[:, 0]
    om = log.rate_at(t_rows) @ cal.axes.T * T  # rad per frame interval
    f = cal.focal
    r2 = ((ys - (h - 1) / 2.0) / f) ** 2
    vel = np.stack([f * om[:, 1] - om[:, 2] * (ys - (h - 1) / 2.0),
                    -f * om[:, 0] * (1 + r2)], axis=-1)
    return fld, disp, vel, neighbours


class GyroMethod:
    """Streaming gyro method: calibrates on the first ``sync_frames``, then one frame in, one out.

    Parameters
    ----------
    timing : SensorTiming
        Readout and reference (frames in top-bottom orientation).
    log : GyroLog
        The gyro samples.
    config : GyroConfig
        What is known of the log; the rest is calibrated.
    fps : float
        Frame rate of the clip (the unit of ``start`` is its frame interval).
    """

    def __init__(self, timing: SensorTiming, log: GyroLog, config: GyroConfig = GyroConfig(),
                 fps: float = 30.0) -> None:
        self.timing = timing
        self.log = log
        self.config = config
        if not fps > 0:
            raise SettingsError(f"frame rate must be positive, got {fps}")
        self.frame_interval = 1.0 / float(fps)
        self.calibration: GyroCalibration | None = None
        if config.axes != "auto" and config.offset is not None and config.focal is not None:
            self.calibration = GyroCalibration(axes_matrix(config.axes), config.offset,
                                               config.focal, distortion=config.distortion)
        self._starts: list[float] = []
        self._small: list[np.ndarray] = []
        self._rows: list[tuple[int, np.ndarray, np.ndarray, np.ndarray]] = []
        self._size = (0, 0)
        self._next = 0

    def push(self, frame: np.ndarray, start: float) -> list[FrameMotion]:
        """Add the next frame (grey, 0-255, top-bottom) starting at ``start`` (frame intervals)."""
        self._size = frame.shape[:2]
        self._starts.append(float(start))
        if self.calibration is None:
            self._measure(frame)
            if len(self._starts) >= self.config.sync_frames:
                self._calibrate()
        return self._ready()

    def flush(self) -> list[FrameMotion]:
        """Return the motion of the frames still pending."""
        if self.calibration is None and self._starts:
            self._calibrate()
        return self._ready()

    def pose(self, start: float) -> np.ndarray | None:
        """Where the gyro puts the picture at the reference time of the frame at ``start``.

        The integrated rotation ``phi = M Theta(t_ref)`` seen as the content's position,
        as :func:`unjello.stabilize.tracked_step` measures it between frames: ``(f phi_y,
        -f phi_x)`` px and the roll ``phi_z`` (radians) -- the small-angle image motion of
        :func:`gyro_field`'s velocity, integrated. None before the calibration.
        """
        cal = self.calibration
        if cal is None:
            return None
        h = self._size[0]
        t = cal.offset + self.timing.reference_time(h, start) * self.frame_interval
        phi = self.log.theta(np.array([t]))[0] @ cal.axes.T
        return np.array([cal.focal * phi[1], -cal.focal * phi[0], phi[2]])

    def _measure(self, frame: np.ndarray) -> None:
        """Row flows of the newest pair, in full-frame pixels."""
        h, w = frame.shape[:2]
        scale = min(1.0, _SYNC_WIDTH / w)
        size = (max(8, round(w * scale)), max(8, round(h * scale)))
        small = cv2.resize(np.asarray(frame, np.float32), size, interpolation=cv2.INTER_AREA)
        self._small.append(small)
        if len(self._small) < 2:
            return
        prev, cur = self._small[-2], self._small[-1]
        flow = optical_flow(cur, prev, "medium", 0, 0)
        y, med, wgt = row_flows(flow, lands_inside(flow))  # pixels whose flow lands inside
        sx, sy = w / size[0], h / size[1]
        self._rows.append((len(self._small) - 1, (y + 0.5) * sy - 0.5,
                           med * np.array([sx, sy]), wgt))
        self._small[-2] = np.empty(0)  # only the newest copy is needed again

    def _calibrate(self) -> None:
        if not self._rows:
            raise InputError("the gyro method needs at least two frames to calibrate the log")
        self.calibration = calibrate(_Rows.stack(self._rows), np.asarray(self._starts),
                                     self.log, self.timing, self.frame_interval, self._size,
                                     self.config)
        self._small, self._rows = [], []

    def _ready(self) -> list[FrameMotion]:
        out: list[FrameMotion] = []
        cal = self.calibration
        if cal is None:
            return out
        first = self.log.time[0] - cal.offset
        last = self.log.time[-1] - cal.offset
        while self._next < len(self._starts):
            start = self._starts[self._next]
            fld, disp, vel, around = gyro_field(self.log, cal, self.timing, start,
                                                self.frame_interval, self._size)
            t = start * self.frame_interval
            inside = first <= t and t + self.frame_interval <= last
            notes = [cal.describe()] if self._next == 0 else []
            if not inside:
                notes.append("outside the gyro log: no rotation known")
            out.append(FrameMotion(self._next, start, disp, vel, ok=inside,
                                   note="; ".join(notes), field=fld, neighbours=around))
            self._next += 1
        return out
