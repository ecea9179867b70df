"""Stabilisation in the same warp: render each frame at a smoothed camera path.

The rolling-shutter correction shows frame ``n`` as it was at its reference time
``t_ref(n)``; its content then sits where the camera's image path ``P`` put it,
``P(t_ref(n))``. :class:`Stabilizer` measures that path between consecutive frames from
points tracked across them and moved to where the correction puts them (eq. 26: the
shift of the frame's centre and the roll, :func:`tracked_step`), or, where too few points
agree, from the integral of the frames' scanline velocity (:func:`reference_step`, the
same integral as eq. 26). It smooths the path and gives each frame a :class:`Reframe` --
a shift and a turn that move the content to the smooth path and a zoom about the centre
that keeps the borders filled. The warper composes it with the correction's backward
map, so the picture is resampled once (:func:`unjello.warp.maps.reframe_maps`).

The smooth path
---------------
A robust Whittaker smoother (:func:`smooth_path`): the path that stays closest to the
camera's under a penalty on its acceleration, the penalty turning from quadratic to
absolute for the few large accelerations. Shake (many small accelerations) is smoothed
as a Gaussian of ``smoothness`` seconds would smooth it; a constant velocity is kept
exactly; a pan that starts or stops turns the path sharply instead of being lagged by a
window, so it needs no large crop. Each frame's smooth position is solved over the
frames within three ``smoothness`` of it -- a bounded look-ahead, so the clip is still
streamed -- and beyond the clip's ends the path goes on along the line fitted to the
frames there. The shift of a frame,
``S(n) - P(n)``, is limited softly to the margin ``m`` the crop leaves
(:func:`soft_limit`: unchanged up to :data:`KNEE` of it), so the limit never jerks.

The crop
--------
``'none'``: no zoom (what the shift uncovers is filled as ``fill`` says, from the
neighbouring frames where the dense method knows them); a fraction ``f``: a constant zoom
``1 / (1 - f)``; ``'auto'``: per frame, the least zoom that keeps its shifted picture
filled, raised to the largest any frame within half a ``smoothness`` needs and
averaged over those frames, so it changes gradually and is never short (at most :data:`MAX_CROP`).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, replace

import cv2
import numpy as np
from scipy import linalg

from .errors import SettingsError
from .motion.dense.camera import ROBUST_KNEE, second_difference_band
from .timing import SensorTiming
from .trajectory import FrameMotion, Reframe

__all__ = ["StabilizeConfig", "Stabilizer", "tracking_copy", "track", "tracked_step",
           "reference_step", "smooth_path", "MAX_CROP", "ROLL_FLOOR", "COHERENT",
           "step_coherence", "crop_request", "soft_limit", "KNEE"]

#: The most the automatic crop takes from each dimension (fraction of the frame), and
#: the margin of ``crop='none'`` for the shift.
MAX_CROP = 0.25

#: Shifts (and rolls) up to this share of their margin are kept as they are
#: (:func:`soft_limit`).
KNEE = 0.7

#: Roll wobble (RMS, smooth path less measured) below which the roll is not stabilised; fully
#: from twice that: the Karma gimbal's 0.039 degrees is noise (``docs/tuning.md#roll_floor``).
ROLL_FLOOR = float(np.radians(0.05))

#: The roll's step coherence (:func:`step_coherence`) above which it is stabilised
#: however little it wobbles, fully from twice that.
COHERENT = 2.0


def step_coherence(path: np.ndarray) -> float:
    """How much a path's steps follow one another, in units of a white noise's spread.

    The mean autocorrelation of the steps (less their mean) at lags 1 and 2, divided by
    its standard deviation for steps of white noise (``1 / sqrt(n)`` per lag, averaged
    over two). A tracker's error on each frame pair is independent of the next pair's,
    so its steps score about 0 +- 1; a real turn of the camera, sampled at the frame
    rate, spans several frames and scores several units. Measured on the stabiliser's
    roll path over the first 90 frames of the real clips (its windows of 55 frames):
    the Karma's gimbal-held GoPro, whose tracked roll is noise, -1.7 to 0.3; the GoPro
    Max, whose roll wobble is real, -2.0 to 5.2 (its first half coherent); the phone in
    a car -1.4 to 6.1 (its roll is above the wobble floor anyway).

    Parameters
    ----------
    path : ndarray of shape (n,)
        Positions, one a frame.

    Returns
    -------
    float
    """
    d = np.diff(path)
    d = d - d.mean()
    energy = float(d @ d)
    n = len(d)
    if n < 8 or energy <= 0.0:
        return 0.0
    ac = [float(d[:-k] @ d[k:]) / energy for k in (1, 2)]
    return 0.5 * (ac[0] + ac[1]) * np.sqrt(2.0 * n)


def crop_request(value: object) -> str | float:
    """Read a crop setting: ``'auto'``, ``'none'`` or a fraction in [0, 0.5).

    Examples
    --------
    >>> crop_request("0.1"), crop_request("auto")
    (0.1, 'auto')
    """
    if isinstance(value, str) and value.strip().lower() in ("auto", "none"):
        return value.strip().lower()
    try:
        f = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise SettingsError(f"crop must be auto, none or a fraction such as 0.1, "
                            f"not {value!r}") from None
    if not 0.0 <= f < 0.5:
        raise SettingsError(f"crop must be a fraction from 0 to 0.5, not {value!r}")
    return f


@dataclass(frozen=True)
class StabilizeConfig:
    """Settings of the stabilisation.

    Parameters
    ----------
    enabled : bool
        Stabilise while correcting.
    smoothness : float
        Standard deviation of the Gaussian that smooths the camera path, seconds.
    crop : {'auto', 'none'} or float
        How the borders a shift uncovers are kept out of the picture (module notes).
    """

    enabled: bool = False
    smoothness: float = 0.3
    crop: str | float = "auto"

    def __post_init__(self) -> None:
        object.__setattr__(self, "crop", crop_request(self.crop))
        if not (isinstance(self.smoothness, (int, float)) and 0 < self.smoothness <= 10):
            raise SettingsError(f"smoothness must be from 0 to 10 seconds, "
                                f"not {self.smoothness!r}")


def reference_step(prev: FrameMotion, cur: FrameMotion, timing: SensorTiming) -> np.ndarray:
    """Return the camera's image motion from ``prev``'s reference time to ``cur``'s, px.

    The integral of the scanline velocity ``v'(t)`` (eq. 26's integrand) from
    ``t_ref(prev)`` to ``t_ref(cur)``: the second half of ``prev``'s rows, the blanking
    between the frames (the velocity interpolated linearly across it), the first half of
    ``cur``'s.

    Examples
    --------
    A constant 5 px per frame interval, frames one interval apart:

    >>> v = np.tile([5.0, 0.0], (10, 1))
    >>> a, b = (FrameMotion(i, float(i), np.zeros((10, 2)), v) for i in (0, 1))
    >>> reference_step(a, b, SensorTiming(0.6)).round(6).tolist()
    [5.0, 0.0]
    """
    h = cur.velocity.shape[0]
    t = np.concatenate([timing.row_times(h, prev.start), timing.row_times(h, cur.start)])
    v = np.concatenate([prev.velocity, cur.velocity])
    a, b = timing.reference_time(h, prev.start), timing.reference_time(h, cur.start)
    grid = np.linspace(a, b, 129)
    vel = np.stack([np.interp(grid, t, v[:, k]) for k in range(2)], axis=1)
    return (0.5 * (vel[1:] + vel[:-1]) * np.diff(grid)[:, None]).sum(axis=0)


def tracking_copy(image: np.ndarray, width: int = 480) -> tuple[np.ndarray, float]:
    """Return the grey 8-bit copy of a frame (0-255) at most ``width`` wide, and its scale."""
    h, w = image.shape[:2]
    scale = min(1.0, width / w)
    size = (max(1, round(w * scale)), max(1, round(h * scale)))
    small = cv2.resize(image, size, interpolation=cv2.INTER_AREA) if scale < 1 else image
    return np.clip(small, 0, 255).astype(np.uint8), scale


def track(prev: tuple[np.ndarray, float], cur: tuple[np.ndarray, float]) -> np.ndarray:
    """Return corners of ``prev`` and where they are in ``cur``, ``(n, 4)``: x0, y0, x1, y1.

    Shi-Tomasi corners tracked by pyramidal Lucas-Kanade on :func:`tracking_copy` copies
    of two frames (grey, top-bottom orientation), in pixels of the frames; only what both
    directions agree on (within half a pixel of the copy) is kept.
    """
    (a, scale), (b, _) = prev, cur
    pts = cv2.goodFeaturesToTrack(a, 300, 0.01, 8)
    if pts is None or len(pts) < 8:
        return np.zeros((0, 4))
    fwd, ok1, _ = cv2.calcOpticalFlowPyrLK(a, b, pts, np.empty(0), winSize=(21, 21),
                                           maxLevel=3)
    back, ok2, _ = cv2.calcOpticalFlowPyrLK(b, a, fwd, np.empty(0), winSize=(21, 21),
                                            maxLevel=3)
    good = (ok1.ravel() == 1) & (ok2.ravel() == 1) & (
        np.linalg.norm((back - pts).reshape(-1, 2), axis=1) < 0.5)
    out = np.concatenate([pts.reshape(-1, 2), fwd.reshape(-1, 2)], axis=1)[good]
    return (out + 0.5) / scale - 0.5


def tracked_step(points: np.ndarray, prev: FrameMotion, cur: FrameMotion,
                 centre: tuple[float, float]) -> np.ndarray | None:
    """Return the camera's motion from ``prev`` to ``cur``, from tracked points.

    Each point is first moved to where the correction puts it (``p = s - Delta(s_y)``,
    eq. 26, per scanline), i.e. to its frame's reference time: a rolling-shutter frame's
    skew is a shear, and a shear fitted by a similarity reads as half its slope of
    rotation. Then a similarity is fitted with RANSAC; ``centre`` is the frame's centre
    (x, y), top-bottom orientation.

    Returns
    -------
    ndarray of shape (3,) or None
        The shift of the frame's centre (x, y, px) and the roll (radians); None when
        fewer than 12 points agree. On simulated hand shake (640x360, readout 0.8) the
        shift is within 0.022 px RMS of the truth, where the integral of the dense
        method's scanline velocity (:func:`reference_step`) is within 0.115 px.
    """
    if len(points) < 12:
        return None
    rows = np.arange(prev.displacement.shape[0], dtype=np.float64)

    def corrected(xy: np.ndarray, fm: FrameMotion) -> np.ndarray:
        d = np.stack([np.interp(xy[:, 1], rows, fm.displacement[:, k]) for k in range(2)],
                     axis=1)
        return (xy - d).astype(np.float32)

    a, b = corrected(points[:, :2], prev), corrected(points[:, 2:], cur)
    m, inliers = cv2.estimateAffinePartial2D(a, b, method=cv2.RANSAC,
                                             ransacReprojThreshold=1.0)
    if m is None or inliers is None or int(inliers.sum()) < 12:
        return None
    c = np.asarray(centre, dtype=np.float64)
    return np.array([*(m[:, :2] @ c + m[:, 2] - c), np.arctan2(m[1, 0], m[0, 0])])


def _extended(path: np.ndarray, lo: int, hi: int, last: int | None, span: int
              ) -> np.ndarray:
    """``path[lo:hi]``, continued before sample 0 and (once known) after ``last``.

    Beyond an end the path goes on along the straight line fitted to its ``span``
    samples there, plus the path's own departures from that line mirrored about the end
    and negated (an odd reflection about the line's end point): a pan that starts or
    ends with the clip goes on, and the end frames' shake cancels in a symmetric smoother
    instead of being taken for the path. Measured by ``benchmarks/stabilise.py`` (90
    simulated frames; residual jitter, px): shake 1.25 -> 1.14, walk 1.59 -> 1.53, pan
    with shake 1.17 -> 1.06 from the bare line to the mirrored departures. A smoother's
    free end, or an odd reflection about the end frame itself, keeps more.
    """
    idx = np.arange(lo, hi)
    end = last if last is not None else len(path) - 1
    out = np.empty((idx.size, path.shape[1]))
    inside = (idx >= 0) & (idx <= end)
    out[inside] = path[idx[inside]]
    for beyond, ks, pivot in ((idx < 0, np.arange(min(span, end + 1)), 0),
                              (idx > end, np.arange(max(0, end + 1 - span), end + 1), end)):
        if beyond.any():
            if ks.size < 2:
                out[beyond] = path[ks[0]]
                continue
            slope, offset = np.polyfit(ks, path[ks], 1)
            j = idx[beyond]
            mirror = np.clip(2 * pivot - j, 0, end)
            out[beyond] = (np.outer(j, slope) + offset
                           - (path[mirror] - (np.outer(mirror, slope) + offset)))
    return out


def smooth_path(path: np.ndarray, stiffness: float, rounds: int = 3) -> np.ndarray:
    """Return the smooth camera path through ``path``: a robust Whittaker smoother.

    Minimises ``sum |S - P|^2 + stiffness sum r_k |S_{k+1} - 2 S_k + S_{k-1}|^2`` (a
    penalty on the path's acceleration, as the trajectory solve's,
    :func:`unjello.motion.dense.camera.solve_camera_trajectory`), with ``rounds`` of
    reweighting that make an acceleration beyond
    :data:`~unjello.motion.dense.camera.ROBUST_KNEE` times the median cost its size rather
    than its square: a pan that starts or stops turns the path sharply, where a
    low-pass filter would lag it by a whole window (and need a large crop), while the
    shake, many small accelerations, is smoothed away. Its ends are free: the path goes
    on straight there.

    Parameters
    ----------
    path : ndarray of shape (n, d)
        Each column is smoothed; the reweighting sees the norm of all columns'
        accelerations.
    stiffness : float
        Weight of the acceleration penalty: ``(sigma / 1.18) ** 4`` smooths like a
        Gaussian of ``sigma`` samples (the same half-power frequency).
    rounds : int

    Examples
    --------
    A pan is kept; a pan from still keeps its corner within a few pixels:

    >>> p = np.stack([3.0 * np.arange(40), np.zeros(40)], axis=1)
    >>> bool(np.allclose(smooth_path(p, 1e4), p, atol=1e-6))
    True
    >>> q = np.stack([8.0 * np.maximum(np.arange(60) - 30, 0), np.zeros(60)], axis=1)
    >>> bool(np.abs(smooth_path(q, 1e4) - q).max() < 4)
    True
    """
    n = len(path)
    if n < 3:
        return path.astype(np.float64).copy()
    data = path.astype(np.float64)
    smooth, relief = data, np.ones(n - 2)
    for _ in range(rounds + 1):
        if rounds:
            # The first weights come from the path itself, where a corner is one sharp
            # acceleration (a smoothed path spreads it like shake, and reweighting from
            # it alone took 30 rounds to turn a corner: 28 -> 3 px).
            accel = np.linalg.norm(np.diff(smooth, 2, axis=0), axis=1)
            knee = max(ROBUST_KNEE * float(np.median(accel)), 1e-9)
            relief = np.minimum(relief, knee / (accel + 1e-12))
        band = stiffness * second_difference_band(n, relief)
        band[2] += 1.0
        smooth = linalg.solveh_banded(band, data)
    return smooth


def soft_limit(x: np.ndarray, limit: np.ndarray | float, knee: float = KNEE) -> np.ndarray:
    """Keep ``|x|`` within ``limit`` without a jerk: unchanged up to ``knee`` of it.

    Beyond the knee the rest of the range is approached along a ``tanh`` (continuous in
    value and slope at the knee). A ``tanh`` over the whole range (``m tanh(x / m)``, as
    this first was) already takes 8 % off a shift of half the margin: on a walk whose
    shake fills the margin, that leaked a share of every shake into the picture.

    Examples
    --------
    >>> soft_limit(np.array([10.0, 40.0, 200.0, -200.0]), 50.0).round(2).tolist()
    [10.0, 39.82, 50.0, -50.0]
    """
    x = np.asarray(x, dtype=np.float64)
    lim = np.asarray(limit, dtype=np.float64)
    bend = knee * lim
    over = np.abs(x) - bend
    room = np.maximum(lim - bend, 1e-12)
    out = np.where(over > 0, np.sign(x) * (bend + room * np.tanh(np.maximum(over, 0) / room)),
                   x)
    return out


def _zoom_need(reframe: np.ndarray, size: np.ndarray) -> float:
    """Return the least zoom that keeps a reframed view inside the frame.

    The view is shifted by ``reframe[:2]`` and turned by ``reframe[2]``; ``size`` is the
    frame's (w, h).
    """
    w, h = size
    dx, dy, a = np.abs(reframe)
    c, s = np.cos(a), np.sin(a)
    need = max((w * c + h * s) / max(w - 2 * dx, 1e-3), (h * c + w * s) / max(h - 2 * dy, 1e-3))
    return float(max(need, 1.0))


class Stabilizer:
    """Give each frame's motion the :class:`Reframe` that puts it on a smooth camera path.

    Frames go in, in order, as the motion method emits them; they come out, reframed,
    once the frames within the smoothing window after them are known (or at
    :meth:`flush`): a look-ahead of three ``smoothness``, four for the automatic crop.

    Parameters
    ----------
    config : StabilizeConfig
    timing : SensorTiming
        Readout and reference of the frames' velocities.
    size : tuple of int
        ``(width, height)`` of the frames, top-bottom orientation.
    fps : float
        Frame rate (``smoothness`` is in seconds).
    """

    def __init__(self, config: StabilizeConfig, timing: SensorTiming, size: tuple[int, int],
                 fps: float) -> None:
        self.timing = timing
        self.size = np.array(size, dtype=np.float64)
        sigma = max(config.smoothness * fps, 1.0)
        self._stiffness = (sigma / 1.18) ** 4
        #: Frames each side of a frame whose path decides its smooth position.
        self.radius = int(np.ceil(3.0 * sigma))
        crop = config.crop
        self._auto = crop == "auto"
        most = 1.0 / (1.0 - (MAX_CROP if crop in ("auto", "none") else float(crop)))
        #: What a shift may use of the frame: the crop's margin (auto: the largest).
        self.margin = 0.5 * self.size * (1.0 - 1.0 / most)
        self.zoom = 1.0 if crop == "none" else most
        # The automatic zoom: the largest need within zr frames, averaged over zr frames.
        self._zr = max(1, int(np.ceil(sigma / 2))) if self._auto else 0
        self.lookahead = self.radius + 2 * self._zr
        # The path: x, y (px) and the roll (radians); grown by doubling, a view per call.
        self._path = np.zeros((256, 3))
        self._n = 0
        self._step = np.zeros(2)
        self._tracks: dict[int, np.ndarray] = {}
        self._poses: dict[int, np.ndarray] = {}
        self._gyro = False  # steps from a gyro: its roll is no noise to leave alone
        w, h = size
        self._centre = ((w - 1) / 2.0, (h - 1) / 2.0)
        #: The roll a frame may be turned by: what uses half the crop's zoom at most.
        self.max_angle = 0.5 * (most - 1.0) * min(w, h) / max(w, h)
        self._shifts: list[np.ndarray] = []
        self._needs: list[float] = []
        self._held: deque[FrameMotion] = deque()
        self._prev: FrameMotion | None = None
        self._done = 0

    def push(self, motions: list[FrameMotion], tracks: dict[int, np.ndarray] | None = None,
             poses: dict[int, np.ndarray] | None = None) -> list[FrameMotion]:
        """Add frames' motions; return those now reframed, in order.

        Parameters
        ----------
        motions : list of FrameMotion
        tracks : dict, optional
            Frame index ``k`` -> :func:`track` from frame ``k - 1`` to ``k`` (without, the
            steps are the scanline velocity's integral and the roll is not stabilised).
        poses : dict, optional
            Frame index ``k`` -> the picture's position and roll at its reference time by
            a gyro (:meth:`unjello.motion.gyro.method.GyroMethod.pose`). Where two consecutive
            frames have one, their difference is the step, and the roll is smoothed
            however little it wobbles (a gyro's roll is not the tracker's noise).
        """
        self._tracks.update(tracks or {})
        self._poses.update(poses or {})
        for fm in motions:
            if self._n == len(self._path):
                self._path = np.concatenate([self._path, np.zeros_like(self._path)])
            if self._prev is not None:
                # Points tracked between the two frames give the step and the roll; where
                # too few agree, the integral of the scanline velocity gives the step (no
                # roll). A frame whose motion is unknown keeps the last step.
                step = None
                if fm.ok and self._prev.ok:
                    pts = self._tracks.pop(fm.index, None)
                    if fm.index in self._poses and self._prev.index in self._poses:
                        step = self._poses[fm.index] - self._poses[self._prev.index]
                        self._gyro = True
                    elif pts is not None:
                        step = tracked_step(pts, self._prev, fm, self._centre)
                    if step is None:
                        step = np.append(reference_step(self._prev, fm, self.timing), 0.0)
                    self._step = step[:2]
                self._path[self._n, :2] = self._path[self._n - 1, :2] + self._step
                self._path[self._n, 2] = self._path[self._n - 1, 2] + (
                    step[2] if step is not None else 0.0)
            self._n += 1
            if self._prev is not None:
                self._poses.pop(self._prev.index, None)
            self._prev = fm
            self._held.append(fm)
        return self._ready(final=False)

    def flush(self) -> list[FrameMotion]:
        """Reframe the frames still held at the end of the clip."""
        return self._ready(final=True)

    def _ready(self, final: bool) -> list[FrameMotion]:
        n = self._n
        path = self._path[:n]
        # Shifts are final once the smoothing window after them is known.
        while len(self._shifts) < n and (final or len(self._shifts) + self.radius < n):
            k = len(self._shifts)
            window = _extended(path, k - self.radius, k + self.radius + 1,
                               n - 1 if final else None, self.radius)
            shift = smooth_path(window[:, :2], self._stiffness)[self.radius] - path[k, :2]
            rolls = smooth_path(window[:, 2:], self._stiffness)[:, 0] - window[:, 2]
            # A roll that wobbles less than ROLL_FLOOR is left alone, fading in up to twice
            # that: below it the measurement's own noise is most of what would be "smoothed"
            # -- unless its steps follow one another as a real turn's do and a tracker's
            # independent errors do not (COHERENT white-noise spreads, fully from twice).
            fade = 1.0
            if not self._gyro:
                wobble = float(np.sqrt(np.mean(rolls ** 2)))
                coherent = step_coherence(window[:, 2]) / COHERENT - 1.0
                fade = float(np.clip(max(wobble / ROLL_FLOOR - 1.0, coherent), 0.0, 1.0))
            roll = fade * rolls[self.radius]
            m = np.maximum(self.margin, 1e-6)
            limited = np.append(soft_limit(shift, m),
                                soft_limit(np.array([roll]), max(self.max_angle, 1e-9)))
            self._shifts.append(limited)
            self._needs.append(_zoom_need(limited, self.size))
        out = []
        while self._held and (final or self._done + self.lookahead < n):
            fm = self._held.popleft()
            shift = self._shifts[self._done]
            at = self._path[self._done]
            out.append(replace(fm, reframe=Reframe(
                (float(shift[0]), float(shift[1])), self._zoom_at(self._done),
                float(shift[2]), (float(at[0]), float(at[1]), float(at[2])))))
            self._tracks.pop(fm.index, None)
            self._done += 1
        return out

    def _zoom_at(self, n: int) -> float:
        """Frame ``n``'s zoom: constant, or (auto) the smoothed envelope of the needs."""
        if not self._auto:
            return self.zoom
        r, hi = self._zr, len(self._needs) - 1
        ks = [k for k in range(n - r, n + r + 1) if 0 <= k <= hi]
        envelope = np.array([max(self._needs[max(0, k - r):min(hi, k + r) + 1]) for k in ks])
        w = np.exp(-0.5 * ((np.array(ks) - n) / max(r / 2.0, 0.5)) ** 2)
        return float(min(self.zoom, w @ envelope / w.sum()))
