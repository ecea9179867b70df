"""Backward maps from a frame's motion: where each output pixel reads its picture.

A per-scanline displacement gives exact maps (:func:`remap_maps`: the row's inverse is a
1-D monotone interpolation); a per-pixel field is inverted by a fixed point
(:func:`field_maps`), on the field's grid (:func:`grid_field`), with fitted objects'
layers in front (:func:`front_maps`); maps are resized to a plane (:func:`resize_maps`),
composed with a reframe (stabilisation, :func:`reframe_maps`) or with other maps
(:func:`compose_maps`). :func:`frame_maps` is a frame's, whatever its motion.
:class:`~unjello.warp.warper.PictureWarper` applies them.
"""

from __future__ import annotations

import cv2
import numpy as np

from .._kernels.field import fixed_point_maps
from ..timing import pixel_grid
from ..trajectory import FrameMotion, Reframe
from .bands import PlaneMaps
from .front_layers import layer_sources
from .scanlines import row_sources

__all__ = ["field_maps", "grid_field", "front_maps", "FRONT_BLEND", "resize_maps",
           "remap_maps", "reframe_maps", "frame_maps", "compose_maps", "FIELD_ITERATIONS",
           "FIELD_TOL"]


def remap_maps(displacement: np.ndarray, width: int,
               out: tuple[np.ndarray, np.ndarray] | None = None
               ) -> tuple[np.ndarray, np.ndarray]:
    """Backward maps ``(map_x, map_y)`` of shape (h, w) for :func:`cv2.remap`.

    Parameters
    ----------
    displacement : ndarray of shape (h, 2)
        Per-scanline ``Delta`` (eq. 26).
    width : int
        Width of the plane.
    out : tuple of ndarray, optional
        Float32 buffers of shape (h, w) to fill (saves allocating them every frame).
    """
    h = displacement.shape[0]
    dx, sy = row_sources(displacement)
    dx = dx.astype(np.float32)
    if out is None:
        out = (np.empty((h, width), np.float32), np.empty((h, width), np.float32))
    map_x, map_y = out
    np.add(np.arange(width, dtype=np.float32)[None, :], dx[:, None], out=map_x)
    np.copyto(map_y, sy.astype(np.float32)[:, None])
    return map_x, map_y


#: Most fixed-point iterations inverting a per-pixel field into backward maps ...
FIELD_ITERATIONS = 6


#: ... a pixel stops once a step moves it by less than this (px).
FIELD_TOL = 0.01


def field_maps(field: np.ndarray, iterations: int = FIELD_ITERATIONS, tol: float = FIELD_TOL,
               frame: tuple[int, int] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Backward maps for a per-pixel forward displacement ``p = s - field(s)``.

    The source ``s`` of every output pixel ``p`` is the fixed point of
    ``s = p + field(s)``, found by iterating from ``s = p + field(p)`` (the field is
    sampled bilinearly at the current estimate), pixel by pixel in one compiled pass
    (:func:`~unjello._kernels.field.fixed_point_maps`: each pixel stops when its own step
    is under ``tol``; 1.5 against 3.3 ms on a 480 x 270 field, where every pixel iterated
    until the largest step was). It converges where the field changes by less than one
    pixel per pixel, i.e. wherever the warp does not fold.

    Parameters
    ----------
    field : ndarray of shape (h, w, 2)
        Per-pixel ``(dx, dy)``.
    iterations : int
        Most fixed-point iterations.
    tol : float
        A pixel stops once a step moves it by less than this (px).
    frame : tuple of int, optional
        ``(height, width)`` of the frame whose pixels the field's values are in, when the
        field is sampled on a coarser grid (the dense method's working copy); default:
        the field's own grid.

    Returns
    -------
    map_x, map_y : ndarray of shape (h, w), float32
        Source positions in pixels of the field's grid (:func:`resize_maps` takes them
        to a frame's size).
    """
    h, w = field.shape[:2]
    return fixed_point_maps(grid_field(field, (h, w), frame), iterations, tol)


def grid_field(field: np.ndarray, grid: tuple[int, int], frame: tuple[int, int] | None
               ) -> np.ndarray:
    """Return a copy of a per-pixel ``field`` in pixels of its ``grid``, from ``frame``'s."""
    f = np.ascontiguousarray(field, np.float32).copy()
    if frame is not None and frame != grid:  # per channel (no broadcast over an axis of 2)
        cv2.multiply(f, (grid[1] / frame[1], grid[0] / frame[0], 0.0, 0.0), dst=f)
    return f


#: Pixels (of the maps' grid) apart within which a layer's source and the maps' blend.
FRONT_BLEND = 1.0


def front_maps(maps: tuple[np.ndarray, np.ndarray], front: np.ndarray,
               frame: tuple[int, int] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Show a layer in front of backward maps: a spinning object over its background.

    ``front`` (h, w, 3) is the layer's backward displacement and its weight at each pixel
    of the frame (:attr:`~unjello.trajectory.FrameMotion.front`). Output pixel ``p``
    takes the layer's source ``q = p + front(p)[:2]`` with the weight the object has at
    ``q``: where it lands (further than :data:`FRONT_BLEND` from the maps' source, all
    or nothing: a position between the two is neither). Elsewhere ``maps`` stay -- also
    where the object was and has turned away from (``docs/history/measurements.md``).

    Examples
    --------
    A layer that takes every pixel from one to its right, for an object covering the
    right half of a 4 x 4 frame: the pixels whose source is the object take it.

    >>> gx, gy = pixel_grid(4, 4)
    >>> layer = np.zeros((4, 4, 3), np.float32); layer[..., 0] = 1.0; layer[:, 2:, 2] = 1.0
    >>> front_maps((gx, gy), layer)[0][0].tolist()
    [0.0, 2.0, 3.0, 3.0]
    """
    qx, qy, lands = layer_sources(front, frame)
    mx, my = maps
    far = np.maximum(np.abs(qx - mx), np.abs(qy - my)) > FRONT_BLEND  # (a pole's specks)
    lands = np.where(far, lands >= 0.5, lands).astype(np.float32)
    return mx + lands * (qx - mx), my + lands * (qy - my)


def resize_maps(map_x: np.ndarray, map_y: np.ndarray, height: int, width: int,
                out: tuple[np.ndarray, np.ndarray] | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    """Backward maps computed at one resolution, for a plane of another (pixel centres).

    Bilinear, the displacement held beyond the outermost samples
    (:class:`~unjello.warp.bands.PlaneMaps`, whole). ``out``: two float32 arrays of
    ``height x width`` to write the maps into.
    """
    if map_x.shape == (height, width):
        return map_x, map_y
    return PlaneMaps(map_x, map_y, height, width).whole(out)


def reframe_maps(maps: tuple[np.ndarray, np.ndarray], reframe: Reframe,
                 frame: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Compose backward maps with a stabilisation's shift and zoom: one resampling.

    Output pixel ``p`` shows the corrected frame at ``q = c + R(-angle) (p - c) / zoom -
    shift`` (:class:`~unjello.trajectory.Reframe`), and the corrected frame's pixel ``q`` comes
    from the source at ``maps(q)``; the composition ``maps(q)`` is what the picture is
    then sampled at, once. ``maps`` is interpolated as a displacement ``maps(q) - q``,
    held at the edges, so a ``q`` beyond the frame keeps the nearest displacement.

    Parameters
    ----------
    maps : tuple of ndarray of shape (gh, gw)
        Backward maps on a grid of ``gh x gw`` samples over the frame (the frame's own
        pixels, or a coarser grid: the values are in the grid's pixels).
    reframe : Reframe
    frame : tuple of int
        ``(height, width)`` of the frame ``shift`` is measured in.

    Returns
    -------
    map_x, map_y : ndarray of shape (gh, gw), float32

    Examples
    --------
    The identity map shifted by 3 px: every output pixel reads 3 px to its left.

    >>> mx, my = pixel_grid(4, 6)
    >>> out = reframe_maps((mx, my), Reframe((3.0, 0.0), 1.0), (4, 6))
    >>> (out[0] - mx).round(3).tolist()[0]
    [-3.0, -3.0, -3.0, -3.0, -3.0, -3.0]
    """
    if reframe.identity:
        return maps
    gh, gw = maps[0].shape
    sx, sy = gw / frame[1], gh / frame[0]
    gx, gy = pixel_grid(gh, gw)
    # The rotation acts in frame pixels: on a grid scaled differently along x and y, its
    # off-diagonal terms carry the ratio of the scales.
    cos, sin = np.cos(reframe.angle) / reframe.zoom, np.sin(reframe.angle) / reframe.zoom
    ux, uy = gx - np.float32((gw - 1) / 2), gy - np.float32((gh - 1) / 2)
    qx = (np.float32(cos) * ux + np.float32(sin * sx / sy) * uy
          + np.float32((gw - 1) / 2 - reframe.shift[0] * sx))
    qy = (np.float32(-sin * sy / sx) * ux + np.float32(cos) * uy
          + np.float32((gh - 1) / 2 - reframe.shift[1] * sy))
    disp = np.dstack([maps[0] - gx, maps[1] - gy])
    d = cv2.remap(disp, qx, qy, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    return qx + d[..., 0], qy + d[..., 1]


def frame_maps(motion: FrameMotion, height: int, width: int
               ) -> tuple[tuple[np.ndarray, np.ndarray], bool]:
    """Backward maps of a frame's whole warp (correction and reframe), top-bottom.

    A per-pixel motion's maps come on its field's grid (coarse: :func:`resize_maps`
    takes them to each plane); a per-scanline one's at ``height x width``.

    Returns
    -------
    maps : tuple of ndarray
    coarse : bool
        True for maps on the field's grid.
    """
    if motion.field is not None:
        maps = field_maps(motion.field, frame=(height, width))
        for layer in motion.front:
            maps = front_maps(maps, layer, frame=(height, width))
        return reframe_maps(maps, motion.reframe, (height, width)), True
    maps = remap_maps(motion.displacement, width)
    return reframe_maps(maps, motion.reframe, (height, width)), False


def compose_maps(first: tuple[np.ndarray, np.ndarray], then: tuple[np.ndarray, np.ndarray]
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Backward maps of warping by ``first``, then by ``then``: ``first(then(o))``.

    ``then`` gives, for every output pixel, where to read the picture ``first`` makes;
    ``first`` is sampled there (bilinear, the edge repeated), so the picture is
    resampled once instead of twice.
    """
    mx, my = (cv2.remap(m, then[0], then[1], cv2.INTER_LINEAR,
                        borderMode=cv2.BORDER_REPLICATE) for m in first)
    return mx, my
