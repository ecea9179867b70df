"""A fitted object's layer in front of the field: where it takes each pixel, where it shows.

A dense frame's :attr:`~unjello.trajectory.FrameMotion.front` holds one layer per object
the correction fitted a motion of its own (a spinner turned back, a near pole's drift):
on the field's grid, the backward displacement of the object's motion (in pixels of the
full frame) and the object's weight at each pixel of the frame. :func:`layer_sources`
says where each output pixel would take the object from and how much of the object is
there; :func:`unjello.warp.maps.front_maps` shows it over the maps and :func:`shown_objects`
tells the neighbours' fill where it is shown.
"""

from __future__ import annotations

import cv2
import numpy as np

from ..timing import pixel_grid

__all__ = ["layer_sources", "shown_objects"]


def layer_sources(front: np.ndarray, frame: tuple[int, int] | None = None
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each grid pixel's source under the layer, and the object's weight there.

    Parameters
    ----------
    front : ndarray of shape (h, w, 3)
        The layer: backward displacement ``(dx, dy)`` and the object's weight.
    frame : tuple of int, optional
        The full frame's (height, width), whose pixels the displacement is in; None: the
        layer's own grid.

    Returns
    -------
    qx, qy, lands : ndarray of shape (h, w), float32
        The source ``p + front(p)[:2]`` (grid pixels) and the weight sampled there.
    """
    h, w = front.shape[:2]
    f = np.ascontiguousarray(front[..., :2], np.float32)
    if frame is not None and frame != (h, w):
        f = f * np.array([w / frame[1], h / frame[0]], dtype=np.float32)
    gx, gy = pixel_grid(h, w)
    qx, qy = gx + f[..., 0], gy + f[..., 1]
    lands = cv2.remap(np.ascontiguousarray(front[..., 2], np.float32), qx, qy,
                      cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    return qx, qy, lands


def shown_objects(front: tuple[np.ndarray, ...], grid: tuple[int, int],
                  frame: tuple[int, int] | None = None) -> np.ndarray | None:
    """Where the output shows a fitted object, on ``grid`` (bool); None without one.

    The object is shown where the weight at a pixel's source under its layer
    (:func:`layer_sources`) is at least a half. ``frame`` as there.
    """
    if not front:
        return None
    shown = np.maximum.reduce([layer_sources(layer, frame)[2] for layer in front])
    if shown.shape != grid:
        shown = cv2.resize(shown, (grid[1], grid[0]), interpolation=cv2.INTER_LINEAR)
    return shown >= 0.5
