"""The gyro's data: its log of angular rates and the settings that describe it.

A gyro log is data, like the :class:`~unjello.trajectory.Trajectory`: the readers in
:mod:`unjello.io` make one (a CSV log, the camera's own telemetry), the gyro method in
:mod:`unjello.motion.gyro.method` synchronises it with the footage (clock offset, axes, focal
length) and turns it into a rotation per scanline. Both import it from here, so the readers
know nothing of the algorithm (Gyroflow splits its gyro source, its synchronisation and its
integration the same way).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import InputError, SettingsError

__all__ = ["GyroLog", "GyroConfig", "axes_matrix"]


@dataclass(frozen=True)
class GyroLog:
    """Angular rate samples of a gyroscope.

    Parameters
    ----------
    time : ndarray of shape (n,)
        Sample times in seconds, increasing (the log's own clock).
    rate : ndarray of shape (n, 3)
        Angular rate about the gyro's x, y, z axes, rad/s.
    """

    time: np.ndarray
    rate: np.ndarray
    angle: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        t = np.asarray(self.time, dtype=np.float64)
        r = np.asarray(self.rate, dtype=np.float64)
        if t.ndim != 1 or r.shape != (t.size, 3) or t.size < 2:
            raise InputError("a gyro log needs at least two samples of time and three rates")
        if not np.all(np.diff(t) > 0):
            raise InputError("gyro sample times must increase")
        object.__setattr__(self, "time", t)
        object.__setattr__(self, "rate", r)
        # Theta(t): the integral of the rate (trapezoid rule), linear between samples.
        from scipy.integrate import cumulative_trapezoid  # on use: slow to import

        object.__setattr__(self, "angle", cumulative_trapezoid(r, t, axis=0, initial=0.0))

    def theta(self, t: np.ndarray) -> np.ndarray:
        """Integrated rate at times ``t`` (seconds), shape ``t.shape + (3,)``.

        Outside the log the angle is held (no rotation is assumed there).
        """
        t = np.asarray(t, dtype=np.float64)
        return np.stack([np.interp(t, self.time, self.angle[:, i]) for i in range(3)], axis=-1)

    def rate_at(self, t: np.ndarray) -> np.ndarray:
        """Angular rate at times ``t`` (seconds), zero outside the log."""
        t = np.asarray(t, dtype=np.float64)
        return np.stack([np.interp(t, self.time, self.rate[:, i], left=0.0, right=0.0)
                         for i in range(3)], axis=-1)


def axes_matrix(spec: str) -> np.ndarray:
    """Camera-from-gyro axis mapping from three letters, e.g. ``"XYZ"`` or ``"Xzy"``.

    Letter ``i`` names the gyro axis that is camera axis ``i`` (x right, y down, z along
    the view, in the frames as unjello reads them top to bottom); lower case negates it.
    """
    if len(spec) != 3 or sorted(spec.upper()) != ["X", "Y", "Z"]:
        raise SettingsError(f"gyro axes must be three letters naming X, Y and Z once each "
                            f"(lower case: negated), got {spec!r}")
    m = np.zeros((3, 3))
    for i, ch in enumerate(spec):
        m[i, "XYZ".index(ch.upper())] = 1.0 if ch.isupper() else -1.0
    return m


def _axes_spec(m: np.ndarray) -> str:
    out = ""
    for i in range(3):
        j = int(np.argmax(np.abs(m[i])))
        out += "XYZ"[j] if m[i, j] > 0 else "xyz"[j]
    return out


@dataclass(frozen=True)
class GyroConfig:
    """Settings of the gyro method.

    Parameters
    ----------
    path : str, optional
        The gyro log (read by :func:`unjello.io.sidecars.read_gyro`; default the
        ``NAME.gyro.csv`` beside the clip).
    layout : str
        Column layout of the log, or ``"auto"``.
    units : {'rad', 'deg'}
        Unit of the logged rates per second.
    axes : str
        :func:`axes_matrix` spec, or ``"auto"`` (found by
        :func:`unjello.motion.gyro.method.calibrate`).
    offset : float, optional
        Time on the log's clock of the first frame's first scanline, seconds; found by
        :func:`unjello.motion.gyro.method.calibrate` if not given.
    focal : float, optional
        Focal length in pixels of the full frame; found by :func:`calibrate` if not
        given.
    distortion : tuple of 4 float, optional
        Fisheye distortion ``k1 .. k4`` of the lens (OpenCV's fisheye model, Gyroflow's
        lens profiles): the rotation is then applied to the undistorted rays and the
        result distorted back, so straight lines stay as the lens draws them. None: a
        pinhole.
    sync_frames : int
        Frames at the start of the clip whose motion calibrates the log (they are held
        until then); at least 30 tell a log of the clip from another one.
    """

    path: str | None = None
    layout: str = "auto"
    units: str = "rad"
    axes: str = "auto"
    offset: float | None = None
    focal: float | None = None
    distortion: tuple[float, float, float, float] | None = None
    sync_frames: int = 60

    def __post_init__(self) -> None:
        if self.axes != "auto":
            axes_matrix(self.axes)
        if self.focal is not None and not self.focal > 0:
            raise SettingsError(f"focal length must be positive, got {self.focal}")
        if self.distortion is not None:
            k = tuple(self.distortion)
            if len(k) != 4 or not all(np.isfinite(v) for v in k):
                raise SettingsError(f"distortion must be four numbers k1,k2,k3,k4, got "
                                    f"{self.distortion!r}")
            object.__setattr__(self, "distortion", tuple(float(v) for v in k))
        if self.sync_frames < 3:
            raise SettingsError("gyro calibration needs at least 3 frames")
