"""Rendering a rolling-shutter clip and its truth: scenes, layers, scanlines in time.

See :mod:`unjello.simulate` for the model.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass

import cv2
import numpy as np

from ..errors import SettingsError
from ..timing import SensorTiming, from_top_bottom, to_top_bottom
from ..trajectory import FrameMotion
from .motion import Motion

__all__ = ["SCENES", "Layer", "SimulatedFrame", "simulate", "scene_layers"]

SCENES = ("planar", "parallax", "object", "propeller", "wheel", "poles")

#: Colours of the ``poles`` scene's poles (RGB), in turn.
_POLE_COLOURS = ((200, 40, 30), (240, 220, 60), (30, 60, 160), (250, 250, 250), (40, 40, 40),
                 (60, 160, 60))


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
                 size: tuple[int, int], travel: tuple[float, float] = (0.0, 0.0)
                 ) -> list[Layer]:
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
        ``poles``: flat-coloured vertical poles over the whole height, 2.2-4.7 % of the
        width wide and 19-41 % apart (14-30 px and 120-260 px at 640), 2.2 times as near
        as the background (parallax: they move 2.2x), placed so that they pass through
        the frame over the camera's ``travel``.
    image : ndarray
        Texture source for the layer (a different image from the background is best).
    camera : callable
        The camera's (background) motion ``D(t)``.
    size : tuple of int
        ``(width, height)`` of the output frame (top-bottom orientation).
    travel : tuple of float
        The least and greatest horizontal displacement of the camera over the clip (px).

    Returns
    -------
    list of Layer
    """
    if kind == "planar":
        return []
    w, h = size
    if kind == "poles":
        return pole_layers(camera, size, travel)
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


def pole_layers(camera: Callable[[np.ndarray], np.ndarray], size: tuple[int, int],
                travel: tuple[float, float], nearer: float = 2.2,
                gap: tuple[float, float] = (120.0, 260.0)) -> list[Layer]:
    """Return flat-coloured vertical poles passing in front: the ``poles`` scene.

    A fixed pseudo-random layout (:func:`scene_layers`), the poles ``nearer`` times as
    near as the background: they move ``nearer`` times the camera's displacement. They
    stand ``gap`` (least, most) apart, in pixels of a frame 640 wide.
    """
    w, h = size
    rng = np.random.default_rng(3)
    poles: list[Layer] = []
    x = -nearer * travel[1] - 0.2 * w
    while x < w + 0.2 * w - nearer * travel[0]:
        width = int(round(w * rng.uniform(14, 30) / 640))
        image = np.empty((h + 40, width + 2, 3), np.float32)
        image[:] = _POLE_COLOURS[len(poles) % len(_POLE_COLOURS)]
        alpha = np.zeros((h + 40, width + 2), np.float32)
        alpha[:, 1:-1] = 1.0
        poles.append(Layer(image, alpha, (x, -20.0), lambda t: nearer * camera(t)))
        x += w * rng.uniform(*gap) / 640
    return poles


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
    layers : {'planar', 'parallax', 'object', 'propeller', 'wheel', 'poles'} or list of Layer
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
        layer_list = scene_layers(layers, tex, motion, (ow, oh), (dmin[0], dmax[0]))
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

