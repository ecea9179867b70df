"""Render rolling-shutter clips with known motion: the ground truth of every test.

A static scene image ``I`` (or a global-shutter video, one scene per frame) is filmed
by a camera whose image-plane displacement is ``D(t)`` (px, time in frame intervals):
the global-shutter frame at time ``t`` is ``G_t(p) = I(p + o - D(t))`` for a crop
origin ``o``, so a static scene point appears at ``w - o + D(t)``. A rolling-shutter
frame takes each scanline ``r`` from the global-shutter frame of its own time (eq. 2):
``S_n(x, r) = G_{t_r}(x, r)`` with ``t_r = t_n + rho r / h`` (:mod:`unjello.timing`);
with an exposure ``e`` (in frame intervals) it averages ``G_t`` over
``[t_r - e, t_r]``. The truth is ``G_{t_ref}`` of each frame, and the true
per-scanline displacement is ``D(t_r) - D(t_ref)``: exactly what a method's
:class:`~unjello.trajectory.FrameMotion` estimates.

Rendering happens in the sensor's top-bottom orientation (:func:`unjello.timing.to_top_bottom`)
and is turned back, so the scan direction is honoured and ``D`` is along the sensor's
rows and columns. With a video source, the scene changes from frame to frame (the
content of source frame ``n`` is used for every scanline of frame ``n``); only the
camera's own motion is rolling-shutter distorted, and that is what the truth describes.

Scenes: ``planar`` (one depth), ``parallax`` (a disc at half the depth, moving twice
as far) and ``object`` (a disc moving on its own); with layers the truth is per pixel.

Motions (all return ``D(t)`` in px, ``t`` in frame intervals, for a frame rate ``fps``):
``pan`` (constant velocity), ``stop`` (pan, then a sudden stop half way, the paper's
Fig. 7), ``diagonal`` (pan in x and y), ``shake`` (hand shake: sinusoids of 1.5-9 Hz),
``jello`` (drone vibration: 23-40 Hz, a few px, on a slow pan), or a JSON file
``{"time_unit": "frame" | "s", "t": [...], "dx": [...], "dy": [...]}`` interpolated
by a cubic spline.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from scipy.interpolate import CubicSpline

from .errors import InputError, SettingsError
from .io.frames import read_image
from .io.sidecars import write_gyro
from .io.sink import FrameSink, check_new, replace, temp_path
from .io.video import VIDEO_SUFFIXES, EncodeOptions, VideoReader
from .timing import SensorTiming, from_top_bottom, to_top_bottom
from .trajectory import FrameMotion, Trajectory

__all__ = ["Motion", "MOTIONS", "SCENES", "Layer", "SimulatedFrame", "simulate",
           "motion_from_spec", "scene_layers", "gyro_samples", "read_scene", "simulate_clip"]

MOTIONS = ("pan", "stop", "diagonal", "shake", "jello", "whip")


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
        Pan speed in px per frame (for pan, stop, diagonal, jello's drift).
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
    def from_rest(cls, vx: float, vy: float, start: float = 2.0, ramp: float = 1.0
                  ) -> Motion:
        """Still until ``start``, then accelerating over ``ramp`` frames to (vx, vy) px/frame.

        Examples
        --------
        >>> Motion.from_rest(10.0, 0.0)(np.array([1.0, 3.0, 5.0]))[:, 0].tolist()
        [0.0, 5.0, 25.0]
        """
        t = np.arange(0, 14, 0.25)
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
                return np.stack([CubicSpline(kt, kx)(t), CubicSpline(kt, ky)(t)], axis=-1)
            return np.stack([np.interp(t, kt, kx), np.interp(t, kt, ky)], axis=-1)
        raise SettingsError(f"unknown motion {self.kind!r}; use one of {', '.join(MOTIONS)}")


def gyro_samples(motion: Motion, focal: float, duration: float, *, rate: float = 400.0,
                 axes: np.ndarray | None = None, start: float = 0.0, noise: float = 0.0,
                 seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Return a gyroscope log of the camera rotation that makes ``motion`` (small angles).

    An image shift of ``v`` px/s at focal length ``f`` px is a rotation of ``v / f``
    rad/s: about the camera's y axis for ``v_x``, about its x axis (negated) for
    ``v_y`` -- the convention of :func:`unjello.motion.gyro.gyro_field`, under which the
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


SCENES = ("planar", "parallax", "object", "propeller", "wheel")


@dataclass(frozen=True)
class Layer:
    """A foreground layer composited over the scene, with its own image motion.

    Parameters
    ----------
    image : ndarray of shape (hl, wl[, C])
        Layer pixels (same channels as the scene).
    alpha : ndarray of shape (hl, wl)
        Opacity in ``[0, 1]``.
    position : tuple of float
        ``(x, y)`` of the layer's top-left in the (top-bottom) output frame at ``D = 0``.
    motion : callable
        ``D_layer(t)``, as :class:`Motion`: pixel ``q`` of the layer appears at
        ``position + q + D_layer(t)``. A layer nearer the camera than the scene moves
        more (parallax); an object moving on its own adds its own motion.
    spin : float
        Rotation about the layer's centre, radians per frame interval (a propeller, a
        wheel): pixel ``q`` appears at ``position + c + R(spin t) (q - c) + D_layer(t)``.
    """

    image: np.ndarray
    alpha: np.ndarray
    position: tuple[float, float]
    motion: Callable[[np.ndarray], np.ndarray]
    spin: float = 0.0

    def place(self, q: np.ndarray, t: np.ndarray) -> np.ndarray:
        """Return where layer pixels ``q`` (..., 2) appear in the frame at times ``t``."""
        c = np.array([self.image.shape[1], self.image.shape[0]], np.float64) / 2.0
        a = self.spin * np.asarray(t, np.float64)
        d = np.asarray(q, np.float64) - c
        rot = np.stack([np.cos(a) * d[..., 0] - np.sin(a) * d[..., 1],
                        np.sin(a) * d[..., 0] + np.cos(a) * d[..., 1]], axis=-1)
        return np.asarray(self.position) + c + rot + self.motion(t)

    def source(self, p: np.ndarray, t: np.ndarray) -> np.ndarray:
        """Return the layer pixel ``q`` that frame position ``p`` (..., 2) shows at ``t``."""
        c = np.array([self.image.shape[1], self.image.shape[0]], np.float64) / 2.0
        a = -self.spin * np.asarray(t, np.float64)
        d = np.asarray(p, np.float64) - np.asarray(self.position) - c - self.motion(t)
        return c + np.stack([np.cos(a) * d[..., 0] - np.sin(a) * d[..., 1],
                             np.sin(a) * d[..., 0] + np.cos(a) * d[..., 1]], axis=-1)


def scene_layers(kind: str, image: np.ndarray, camera: Callable[[np.ndarray], np.ndarray],
                 size: tuple[int, int]) -> list[Layer]:
    """Foreground layers of the built-in scenes, in top-bottom orientation.

    Parameters
    ----------
    kind : {'planar', 'parallax', 'object', 'propeller', 'wheel'}
        ``planar``: none. ``parallax``: a second depth, a textured disc covering a third
        of the frame, twice as near as the background (moves 2x). ``object``: a disc
        moving on its own at (3.5, 1.2) px per frame over the static, panned scene.
        ``propeller``: three textured blades spinning at 6 rev/s (at 30 fps) about the
        frame's centre, carried with the camera (a drone's own propeller, say).
        ``wheel``: a textured disc with five spokes' cut-outs spinning at 4 rev/s.
    image : ndarray
        Texture source for the layer (a different image from the background is best).
    camera : callable
        The camera's (background) motion ``D(t)``.
    size : tuple of int
        ``(width, height)`` of the output frame (top-bottom orientation).

    Returns
    -------
    list of Layer
    """
    if kind == "planar":
        return []
    w, h = size
    r = int(min(w, h) * 0.3)
    tex = cv2.resize(image, (2 * r, 2 * r), interpolation=cv2.INTER_AREA)
    yy, xx = np.mgrid[0:2 * r, 0:2 * r]
    alpha = np.clip(r - np.hypot(xx - r + 0.5, yy - r + 0.5) + 0.5, 0, 1).astype(np.float32)
    pos = (w / 2 - r, h / 2 - r)
    if kind == "parallax":
        return [Layer(tex, alpha, pos, lambda t: 2.0 * camera(t))]
    if kind == "object":
        own = np.array([3.5, 1.2])
        return [Layer(tex, alpha, pos,
                      lambda t: camera(t) + np.asarray(t)[..., None] * own)]
    if kind in ("propeller", "wheel"):
        ang = np.arctan2(yy - r + 0.5, xx - r + 0.5)
        rad = np.hypot(xx - r + 0.5, yy - r + 0.5)
        if kind == "propeller":  # three blades, a hub
            blade = np.cos(3 * ang) > 0.6
            shape = ((blade & (rad < r)) | (rad < 0.18 * r)).astype(np.float32)
            spin = 2 * np.pi * 6.0 / 30.0
        else:  # a rim, a hub and five spokes
            spokes = np.cos(5 * ang) > 0.8
            shape = ((rad > 0.8 * r) | (rad < 0.25 * r) | spokes).astype(np.float32)
            shape *= (rad < r)
            spin = 2 * np.pi * 4.0 / 30.0
        alpha = cv2.GaussianBlur(shape, (0, 0), 0.7)
        return [Layer(tex, alpha, pos, camera, spin=spin)]
    raise SettingsError(f"unknown scene {kind!r}; use one of {', '.join(SCENES)}")


@dataclass(frozen=True)
class SimulatedFrame:
    """One rendered frame: rolling-shutter image, global-shutter truth, true motion.

    ``layer`` marks, per pixel of the rolling-shutter frame, the layer it shows
    (0: the scene, 1..: the foreground layers).
    """

    rolling: np.ndarray
    truth: np.ndarray
    motion: FrameMotion
    layer: np.ndarray | None = None


def _render_layer(layer: Layer, times: np.ndarray, width: int
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Layer colour and alpha in the output frame, row ``r`` at ``times[r]``."""
    h = times.shape[0]
    if layer.spin:
        grid = np.stack(np.meshgrid(np.arange(width), np.arange(h)), axis=-1)
        q = layer.source(grid, np.broadcast_to(times[:, None], (h, width)))
        map_x = np.ascontiguousarray(q[..., 0], dtype=np.float32)
        map_y = np.ascontiguousarray(q[..., 1], dtype=np.float32)
    else:
        disp = layer.motion(times)
        map_x = (np.arange(width, dtype=np.float32)[None, :]
                 - (layer.position[0] + disp[:, 0])[:, None].astype(np.float32))
        map_y = np.ascontiguousarray(np.broadcast_to(
            (np.arange(h) - layer.position[1] - disp[:, 1])[:, None].astype(np.float32),
            (h, width)))
    img = cv2.remap(layer.image.astype(np.float32), map_x, map_y, cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    a = cv2.remap(layer.alpha.astype(np.float32), map_x, map_y, cv2.INTER_LINEAR,
                  borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    return img, a


def _composite(base: np.ndarray, layers: list[Layer], times: np.ndarray, width: int
               ) -> tuple[np.ndarray, np.ndarray]:
    out = base
    top = np.zeros(base.shape[:2], np.int32)
    for i, layer in enumerate(layers, start=1):
        img, a = _render_layer(layer, times, width)
        aa = a[..., None] if out.ndim == 3 else a
        out = aa * img + (1 - aa) * out
        top[a > 0.5] = i
    return out, top


def _render(scene: np.ndarray, origin: np.ndarray, disp: np.ndarray, width: int) -> np.ndarray:
    """Sample ``scene`` at ``(x, r) + origin - disp[r]`` for every row ``r``."""
    h = disp.shape[0]
    map_x = (np.arange(width, dtype=np.float32)[None, :]
             + (origin[0] - disp[:, 0])[:, None].astype(np.float32))
    map_y = np.broadcast_to((np.arange(h) + origin[1] - disp[:, 1])[:, None].astype(np.float32),
                            (h, width))
    return cv2.remap(scene, map_x, np.ascontiguousarray(map_y), cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_REFLECT_101)


def simulate(
    scene: np.ndarray | Callable[[int], np.ndarray],
    motion: Motion,
    timing: SensorTiming,
    n_frames: int,
    *,
    size: tuple[int, int] | None = None,
    exposure: float = 0.0,
    frame_starts: np.ndarray | None = None,
    layers: str | list[Layer] = "planar",
    layer_image: np.ndarray | None = None,
) -> Iterator[SimulatedFrame]:
    """Render a rolling-shutter clip and its global-shutter truth.

    Parameters
    ----------
    scene : ndarray of shape (H, W[, C]) or callable
        A still image panned over, or ``scene(n)`` returning the scene of frame ``n``
        (a global-shutter video), in coded orientation.
    motion : Motion
        Camera displacement ``D(t)`` in the sensor's top-bottom frame.
    timing : SensorTiming
        Readout, scan direction, reference.
    n_frames : int
        Number of frames.
    size : tuple of int, optional
        Output ``(width, height)`` in coded orientation; default: as large as the scene
        allows for a still image (it is enlarged when the motion needs more room), the
        scene's own size for a video.
    exposure : float
        Exposure time in frame intervals (motion blur), 0 for none.
    frame_starts : ndarray of shape (n_frames,), optional
        Start time of each frame (variable frame rate); default ``0, 1, 2, ...``.
    layers : {'planar', 'parallax', 'object'} or list of Layer
        Foreground layers (see :func:`scene_layers`); with layers the truth carries a
        per-pixel displacement ``field``.
    layer_image : ndarray, optional
        Texture of the built-in layers (default: the scene flipped upside down).

    Yields
    ------
    SimulatedFrame
    """
    if n_frames < 1:
        raise SettingsError("n_frames must be at least 1")
    starts = np.arange(n_frames, dtype=np.float64) if frame_starts is None else np.asarray(
        frame_starts, dtype=np.float64)
    first = scene(0) if callable(scene) else scene
    probe = to_top_bottom(first, timing.direction)
    sh, sw = probe.shape[:2]
    if size is None:
        ow, oh = (sw, sh) if callable(scene) else (int(sw * 0.75), int(sh * 0.75))
    else:
        ow, oh = (size if timing.direction in ("top-bottom", "bottom-top")
                  else (size[1], size[0]))
    # Range of the displacement over the clip, to place the crop inside the scene.
    t_all = np.concatenate([timing.row_times(oh, s) for s in starts]
                           + [starts - exposure]) if n_frames else np.zeros(1)
    d_all = motion(t_all)
    dmin, dmax = d_all.min(axis=0), d_all.max(axis=0)
    need = np.array([ow, oh]) + (dmax - dmin) + 4
    scale = 1.0
    if not callable(scene):
        scale = float(max(1.0, need[0] / sw, need[1] / sh))
    origin = dmax + 2 + (np.array([sw, sh]) * scale - need) / 2.0

    def scene_tb(n: int) -> np.ndarray:
        img = to_top_bottom(scene(n) if callable(scene) else first, timing.direction)
        img = img.astype(np.float32)
        if scale > 1.0:
            img = cv2.resize(img, None, fx=scale, fy=scale, interpolation=cv2.INTER_CUBIC)
        return img

    still = None if callable(scene) else scene_tb(0)
    dtype = first.dtype
    n_sub = max(1, int(np.ceil(exposure * oh / 4))) if exposure > 0 else 1
    if isinstance(layers, str):
        tex = layer_image if layer_image is not None else first[::-1]
        tex = to_top_bottom(tex, timing.direction).astype(np.float32)
        layer_list = scene_layers(layers, tex, motion, (ow, oh))
    else:
        layer_list = list(layers)
    for n in range(n_frames):
        img = still if still is not None else scene_tb(n)
        t_rows = timing.row_times(oh, starts[n])
        top = None
        if exposure > 0:
            acc = np.zeros((oh, ow) + img.shape[2:], np.float32)
            for j in range(n_sub):
                tj = t_rows - exposure * (j + 0.5) / n_sub
                frame_j, top = _composite(_render(img, origin, motion(tj), ow), layer_list,
                                          tj, ow)
                acc += frame_j
            rs = acc / n_sub
            _, top = _composite(_render(img, origin, motion(t_rows), ow), layer_list, t_rows,
                                ow)
        else:
            rs, top = _composite(_render(img, origin, motion(t_rows), ow), layer_list,
                                 t_rows, ow)
        t_ref = timing.reference_time(oh, starts[n])
        ref_rows = np.full(oh, t_ref)
        d_ref = motion(np.array([t_ref]))[0]
        gs, _ = _composite(_render(img, origin, np.tile(d_ref, (oh, 1)), ow), layer_list,
                           ref_rows, ow)
        eps = 1e-3
        vel = (motion(t_rows + eps) - motion(t_rows - eps)) / (2 * eps)
        disp = motion(t_rows) - d_ref
        field = None
        if layer_list:
            field = np.repeat(disp[:, None, :], ow, axis=1)
            grid = np.stack(np.meshgrid(np.arange(ow), np.arange(oh)), axis=-1)
            row_t = np.broadcast_to(t_rows[:, None], (oh, ow))
            for i, layer in enumerate(layer_list, start=1):
                sel = top == i
                # Where the layer point a pixel shows was at the reference time.
                q = layer.source(grid[sel], row_t[sel])
                field[sel] = grid[sel] - layer.place(q, np.full(q.shape[0], t_ref))
        fm = FrameMotion(n, float(starts[n]), disp, vel, field=field)
        yield SimulatedFrame(
            rolling=_to_dtype(from_top_bottom(rs, timing.direction), dtype),
            truth=_to_dtype(from_top_bottom(gs, timing.direction), dtype),
            motion=fm,
            layer=from_top_bottom(top, timing.direction) if layer_list else None,
        )


def _to_dtype(img: np.ndarray, dtype: np.dtype) -> np.ndarray:
    if np.issubdtype(dtype, np.integer):
        info = np.iinfo(dtype)
        return np.clip(np.rint(img), info.min, info.max).astype(dtype)
    return img.astype(dtype)


def read_scene(path: str | os.PathLike) -> tuple[Callable[[int], np.ndarray] | np.ndarray,
                                                     float | None]:
    """Open a simulation source: an image, or a video read frame by frame in order.

    Returns
    -------
    scene : ndarray or callable
        The image, or ``scene(n)`` returning video frame ``n`` (sequential access; the
        last frame repeats past the end).
    fps : float or None
        The video's frame rate.
    """
    p = Path(path)
    if not p.exists():
        raise InputError(f"{p}: no such file")
    if p.suffix.lower() not in VIDEO_SUFFIXES:
        return read_image(p), None
    reader = VideoReader(p)
    frames = reader.rgb_frames()
    state: dict = {"n": -1, "img": None}

    def scene(n: int) -> np.ndarray:
        while state["n"] < n:
            nxt = next(frames, None)
            if nxt is None:
                if state["img"] is None:
                    raise InputError(f"{p}: the video has no frames")
                break
            state["n"] += 1
            state["img"] = nxt
        return state["img"]

    return scene, reader.info.fps


def simulate_clip(source: str | os.PathLike, rolling_out: str | os.PathLike,
                  truth_out: str | os.PathLike, *, motion: str = "pan",
                  timing: SensorTiming = SensorTiming(), frames: int = 30,
                  fps: float | None = None, size: tuple[int, int] | None = None,
                  speed: float = 8.0, amplitude: float = 1.0, exposure: float = 0.0,
                  overwrite: bool = False, truth_motion: str | os.PathLike | None = None,
                  encode: EncodeOptions = EncodeOptions(),
                  gyro_out: str | os.PathLike | None = None) -> Trajectory:
    """Render a rolling-shutter clip and its global-shutter truth to files.

    Parameters
    ----------
    source : path-like
        A still image (panned over) or a global-shutter video.
    rolling_out, truth_out : path-like
        Outputs: video files (``.mp4`` ...) or folders of PNG frames.
    motion : str
        A motion name of :data:`unjello.simulate.MOTIONS` or a JSON file.
    timing : SensorTiming
        Readout, direction, reference.
    frames : int
        Number of frames.
    fps : float, optional
        Frame rate (default: the source video's, else 30).
    size : tuple of int, optional
        Output ``(width, height)``.
    speed, amplitude, exposure : float
        See :class:`unjello.simulate.Motion` and :func:`unjello.simulate.simulate`.
    overwrite : bool
        Replace existing outputs.
    truth_motion : path-like, optional
        Where to write the true trajectory (default ``<truth_out>.motion.json``).
    encode : EncodeOptions
        Encoder settings of video outputs.
    gyro_out : path-like, optional
        Also write a 400 Hz gyroscope log of the motion (CSV: time in s from the first
        frame, then rad/s about x, y, z), as from a lens of 8 times the frame's width
        (:func:`unjello.simulate.gyro_samples`).

    Returns
    -------
    Trajectory
        The true per-scanline motion.
    """
    check_new(gyro_out, overwrite)

    scene, src_fps = read_scene(source)
    fps = float(fps or src_fps or 30.0)
    mot = motion_from_spec(motion, fps=fps, speed=speed, amplitude=amplitude, n_frames=frames)
    truth_motion = Path(truth_motion or f"{truth_out}.motion.json")
    traj: Trajectory | None = None
    with FrameSink(rolling_out, fps, overwrite, encode) as rs_sink, \
            FrameSink(truth_out, fps, overwrite, encode) as gs_sink:
        for sf in simulate(scene, mot, timing, frames, size=size, exposure=exposure):
            if traj is None:
                h, w = sf.rolling.shape[:2]
                traj = Trajectory(timing, (w, h), method="truth")
            rs_sink.write(sf.rolling)
            gs_sink.write(sf.truth)
            traj.frames.append(sf.motion)
    assert traj is not None
    traj.save(truth_motion)
    if gyro_out is not None:
        t, rates = gyro_samples(mot, 8.0 * traj.size[0], frames / fps)
        tmp = temp_path(Path(gyro_out))
        write_gyro(tmp, t, rates)
        replace(tmp, Path(gyro_out))
    return traj
