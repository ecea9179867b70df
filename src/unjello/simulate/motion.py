"""The simulator's camera motions: pans, stops, hand shake, drone jello, whip pans, files.

Each returns the image-plane displacement ``D(t)`` in px, ``t`` in frame intervals (see
:mod:`unjello.simulate`), and the gyro samples of a rotating camera moving so.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError, SettingsError

__all__ = ["Motion", "MOTIONS", "Vibration", "WALK_SHAKE", "gyro_samples", "motion_from_spec"]

#: The walk's shake, in units of ``'shake'``'s: frame-to-frame jitter of 11.6 px per
#: frame squared at 640x360 on a 2 px/frame pan, the walk of issue 31 (11.4).
WALK_SHAKE = 3.6

MOTIONS = ("pan", "stop", "diagonal", "shake", "walk", "jello", "whip")


@dataclass(frozen=True)
class Motion:
    """Camera displacement ``D(t)`` in the image plane.

    Parameters
    ----------
    kind : str
        One of :data:`MOTIONS` or ``'spline'``.
    fps : float
        Frame rate, to turn Hz into cycles per frame.
    speed : float
        Pan speed in px per frame (for pan, stop, diagonal, walk, jello's drift).
    amplitude : float
        Scale of the shake/jello amplitudes (1 = the defaults below).
    stop_at : float
        Time (frames) of the sudden stop of ``'stop'``.
    start_at : float
        Time (frames) a ``'whip'`` pan starts from still; it reaches ``speed`` 1.5 frame
        intervals later (a whip pan, or a car pulling away, films a still start).
    knots : tuple
        ``(t, dx, dy)`` arrays of a ``'spline'`` motion, ``t`` in frames.
    """

    kind: str = "pan"
    fps: float = 30.0
    speed: float = 8.0
    amplitude: float = 1.0
    stop_at: float = 5.0
    knots: tuple = ()
    start_at: float = 2.0

    @classmethod
    def from_rest(cls, vx: float, vy: float, start: float = 2.0, ramp: float = 1.0,
                  until: float = 14.0) -> Motion:
        """Still until ``start``, then accelerating over ``ramp`` frames to (vx, vy) px/frame.

        ``until``: the last frame time it is defined for (knots every quarter frame).

        Examples
        --------
        >>> Motion.from_rest(10.0, 0.0)(np.array([1.0, 3.0, 5.0]))[:, 0].tolist()
        [0.0, 5.0, 25.0]
        """
        t = np.arange(0, until, 0.25)
        s = np.where(t < start, 0.0, np.where(t < start + ramp, (t - start) ** 2 / (2 * ramp),
                                              ramp / 2 + (t - start - ramp)))
        return cls("spline", knots=(tuple(t), tuple(vx * s), tuple(vy * s)))

    @classmethod
    def steps(cls, velocities: Sequence[tuple[float, float]], at: Sequence[float]) -> Motion:
        """Constant velocities (px/frame) changing within a quarter frame at the times ``at``.

        Examples
        --------
        >>> Motion.steps([(4, 0), (10, 2)], [2.0])(np.array([2.0, 4.0])).tolist()
        [[8.0, 0.0], [28.0, 4.0]]
        """
        t = np.arange(0, 14, 0.25)
        which = np.searchsorted(np.asarray(at, dtype=np.float64), t, side="right")
        vel = np.asarray(velocities, dtype=np.float64)[which]
        pos = np.concatenate([[[0.0, 0.0]], np.cumsum(0.25 * vel[:-1], axis=0)])
        return cls("spline", knots=(tuple(t), tuple(pos[:, 0]), tuple(pos[:, 1])))

    def __call__(self, t: np.ndarray) -> np.ndarray:
        """Return ``D(t)`` as an array of shape ``t.shape + (2,)``."""
        t = np.asarray(t, dtype=np.float64)
        z = np.zeros_like(t)
        if self.kind == "pan":
            return np.stack([self.speed * t, z], axis=-1)
        if self.kind == "diagonal":
            return np.stack([self.speed * t, 0.6 * self.speed * t], axis=-1)
        if self.kind == "stop":
            tt = np.minimum(t, self.stop_at)
            return np.stack([self.speed * tt, z], axis=-1)
        if self.kind == "whip":
            ramp = 1.5
            tt = t - self.start_at
            pan = np.where(tt < 0, 0.0, np.where(tt < ramp, self.speed * tt ** 2 / (2 * ramp),
                                                 self.speed * (tt - ramp / 2)))
            return np.stack([pan, z], axis=-1)
        if self.kind == "shake":
            sec = t / self.fps
            # (Hz, amplitude x px, amplitude y px, phase)
            waves = ((1.5, 6.0, 4.0, 0.3), (2.7, 3.0, 4.0, 1.1), (4.3, 2.5, 1.5, 2.0),
                     (6.1, 1.2, 1.4, 0.7), (8.9, 0.8, 0.6, 2.9))
            x = sum(ax * np.sin(2 * np.pi * f * sec + ph) for f, ax, _, ph in waves)
            y = sum(ay * np.cos(2 * np.pi * f * sec + ph) for f, _, ay, ph in waves)
            return self.amplitude * np.stack([x, y], axis=-1)
        if self.kind == "walk":  # hand-held while walking: shake on a slow pan
            shake = Motion("shake", fps=self.fps, amplitude=WALK_SHAKE * self.amplitude)(t)
            return shake + np.stack([self.speed * t, z], axis=-1)
        if self.kind == "jello":
            sec = t / self.fps
            vib = ((23.0, 2.0, 1.0, 0.4), (31.0, 1.0, 2.0, 1.7), (39.0, 1.0, 0.5, 2.3))
            x = sum(ax * np.sin(2 * np.pi * f * sec + ph) for f, ax, _, ph in vib)
            y = sum(ay * np.sin(2 * np.pi * f * sec + ph + 0.5) for f, _, ay, ph in vib)
            drift = 0.25 * self.speed * t
            return np.stack([self.amplitude * x + drift, self.amplitude * y], axis=-1)
        if self.kind == "spline":
            kt, kx, ky = (np.asarray(a, dtype=np.float64) for a in self.knots)
            if kt.size >= 4:
                from scipy.interpolate import CubicSpline  # here: correcting never needs it

                return np.stack([CubicSpline(kt, kx)(t), CubicSpline(kt, ky)(t)], axis=-1)
            return np.stack([np.interp(t, kt, kx), np.interp(t, kt, ky)], axis=-1)
        raise SettingsError(f"unknown motion {self.kind!r}; use one of {', '.join(MOTIONS)}")


@dataclass(frozen=True)
class Vibration:
    """Drone jello of chosen frequencies on a steady drift: ``D(t)`` in px.

    Parameters
    ----------
    across, updown : tuple of (Hz, px)
        Sinusoids along the rows (x) and across them (y): frequency and amplitude.
    drift : float
        Pan along x, px per second.
    fps : float
        Frame rate, to turn Hz and seconds into frame intervals.
    during : tuple of float
        The frame times the mount vibrates in (a drone that lands, or takes off);
        it drifts throughout.

    Examples
    --------
    >>> v = Vibration(((30.0, 2.0),), (), drift=60.0, fps=30.0)
    >>> np.round(v(np.array([0.0, 1.0])), 6).tolist()  # whole cycles a frame: drift only
    [[0.0, 0.0], [2.0, 0.0]]
    """

    across: tuple[tuple[float, float], ...]
    updown: tuple[tuple[float, float], ...] = ()
    drift: float = 0.0
    fps: float = 30.0
    during: tuple[float, float] = (-np.inf, np.inf)

    def __call__(self, t: np.ndarray) -> np.ndarray:
        """Return ``D(t)`` as an array of shape ``t.shape + (2,)``."""
        t = np.asarray(t, dtype=np.float64)
        sec = t / self.fps
        on = ((t >= self.during[0]) & (t < self.during[1])).astype(np.float64)
        x = sum((a * np.sin(2 * np.pi * f * sec + 0.7 * k)
                 for k, (f, a) in enumerate(self.across)), np.zeros_like(sec))
        y = sum((a * np.sin(2 * np.pi * f * sec + 1.9 + 0.7 * k)
                 for k, (f, a) in enumerate(self.updown)), np.zeros_like(sec))
        return np.stack([on * x + self.drift * sec, on * y], axis=-1)


def gyro_samples(motion: Motion, focal: float, duration: float, *, rate: float = 400.0,
                 axes: np.ndarray | None = None, start: float = 0.0, noise: float = 0.0,
                 seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Return a gyroscope log of the camera rotation that makes ``motion`` (small angles).

    An image shift of ``v`` px/s at focal length ``f`` px is a rotation of ``v / f``
    rad/s: about the camera's y axis for ``v_x``, about its x axis (negated) for
    ``v_y`` -- the convention of :func:`unjello.motion.gyro.method.gyro_field`, under which the
    log reproduces the motion for a focal length much larger than the frame.

    Parameters
    ----------
    motion : Motion
        The image-plane displacement ``D(t)`` (``t`` in frames, at ``motion.fps``).
    focal : float
        Focal length, pixels.
    duration : float
        Seconds of log from video time 0 (one second more is logged on each side).
    rate : float
        Samples per second.
    axes : ndarray of shape (3, 3), optional
        Camera-from-gyro axis mapping of the mounting (default identity).
    start : float
        Log clock time of video time 0, seconds.
    noise : float
        Standard deviation of white noise added to each rate, rad/s.
    seed : int
        Noise seed.

    Returns
    -------
    time : ndarray of shape (n,)
        Seconds on the log's clock.
    rates : ndarray of shape (n, 3)
        rad/s about the gyro's axes.
    """
    t = np.arange(-1.0, duration + 1.0, 1.0 / rate)
    eps = 1e-3
    frames = t * motion.fps
    v = (motion(frames + eps) - motion(frames - eps)) / (2 * eps) * motion.fps  # px/s
    cam = np.stack([-v[:, 1] / focal, v[:, 0] / focal, np.zeros(t.size)], axis=-1)
    m = np.eye(3) if axes is None else np.asarray(axes, dtype=np.float64)
    rates = cam @ m  # camera = m @ gyro, so gyro = m.T @ camera
    if noise > 0:
        rates = rates + np.random.default_rng(seed).normal(0.0, noise, rates.shape)
    return t + start, rates


def motion_from_spec(spec: str, fps: float = 30.0, speed: float = 8.0, amplitude: float = 1.0,
                     stop_at: float | None = None, n_frames: int = 10) -> Motion:
    """Build a :class:`Motion` from a name or a JSON file path.

    Parameters
    ----------
    spec : str
        A name in :data:`MOTIONS`, or a path to a JSON trajectory.
    fps, speed, amplitude : float
        See :class:`Motion`.
    stop_at : float, optional
        Stop time for ``'stop'`` (default: half the clip).
    n_frames : int
        Clip length, for the default stop time.

    Returns
    -------
    Motion
    """
    if spec in MOTIONS:
        return Motion(spec, fps, speed, amplitude,
                      stop_at if stop_at is not None else n_frames / 2.0)
    path = Path(spec)
    if not path.suffix.lower() == ".json":
        raise SettingsError(f"motion must be one of {', '.join(MOTIONS)} or a .json file")
    try:
        doc = json.loads(path.read_text())
        t = np.asarray(doc["t"], dtype=np.float64)
        dx = np.asarray(doc["dx"], dtype=np.float64)
        dy = np.asarray(doc.get("dy", np.zeros_like(dx)), dtype=np.float64)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise InputError(f"cannot read motion file {spec}: {exc}") from None
    if not (t.shape == dx.shape == dy.shape) or t.size < 2 or np.any(np.diff(t) <= 0):
        raise InputError(f"motion file {spec}: t, dx, dy must be equal-length, t increasing")
    if doc.get("time_unit", "frame") in ("s", "seconds"):
        t = t * fps
    return Motion("spline", fps, knots=(tuple(t), tuple(dx), tuple(dy)))

