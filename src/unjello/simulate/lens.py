"""A rotating rolling-shutter camera seen through its lens, pinhole or fisheye.

:func:`unjello.simulate.simulate` moves the picture in the image plane, which a gyro
describes only for a long lens. Here the camera *rotates*, as a hand-held or action
camera does, and its lens may be a fisheye (OpenCV's model, as in Gyroflow's profiles):
pixel ``p`` of the row read at time ``t`` sees the world direction
``R(t)^T undistort(p)``, with ``R(t)`` the rotation by ``Theta(t)``, the integral of the
angular rate (the gyro method's own first-order model). The world is a textured plane far
away (a photo at ``z = 1``). The global-shutter truth is the same frame with every row at
the reference time; the rates come back as the :class:`~unjello.gyrolog.GyroLog` the
camera's gyro would have recorded.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from ..gyrolog import GyroLog
from ..lens import Lens
from ..timing import SensorTiming

__all__ = ["RotatingFrame", "simulate_rotation"]


@dataclass(frozen=True)
class RotatingFrame:
    """One frame of a rotating camera: rolling shutter, and the global-shutter truth."""

    rolling: np.ndarray
    truth: np.ndarray
    start: float


def _rays(size: tuple[int, int], focal: float,
          distortion: tuple[float, ...] | None) -> np.ndarray:
    """Undistorted ray ``(x, y)`` (z = 1) of every pixel, shape ``(h, w, 2)``."""
    w, h = size
    gx, gy = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
    return Lens(focal, distortion).undistort(np.stack([gx, gy], axis=-1), (h, w))


def simulate_rotation(scene: np.ndarray, rate: Callable[[np.ndarray], np.ndarray],
                      timing: SensorTiming, frames: int, *, size: tuple[int, int],
                      focal: float, distortion: tuple[float, float, float, float] | None = None,
                      fps: float = 30.0, scene_focal: float | None = None
                      ) -> tuple[list[RotatingFrame], GyroLog]:
    """Render a rotating camera's clip through its lens.

    Parameters
    ----------
    scene : ndarray of shape (H, W[, C])
        The far-away world, seen through its centre half-way through the clip.
    rate : callable
        ``rate(t)`` -> angular rate (rad/s) about the camera's x, y, z axes, shape
        ``t.shape + (3,)``, ``t`` in seconds.
    timing : SensorTiming
        Readout (top to bottom) and reference.
    frames : int
        Frames to render, at ``fps``.
    size : (int, int)
        Width and height.
    focal : float
        Focal length, pixels.
    distortion : tuple of 4 float, optional
        Fisheye ``k1 .. k4``; None: a pinhole.
    fps : float
        Frame rate.
    scene_focal : float, optional
        Pixels of ``scene`` per unit of the world plane (default: the widest ray reaches
        the scene's edge).

    Returns
    -------
    frames : list of RotatingFrame
    log : GyroLog
        The rates at 1 kHz from one second before the clip to one after.
    """
    w, h = size
    t = np.arange(-1.0, frames / fps + 1.0, 1e-3)
    log = GyroLog(t, np.asarray(rate(t), dtype=np.float64))
    rays = _rays(size, focal, distortion)
    homog = np.concatenate([rays, np.ones((h, w, 1))], axis=-1)
    sh, sw = scene.shape[:2]
    s_f = scene_focal or 0.5 * min(sh, sw) / float(np.abs(rays).max() * 1.2)

    zero = log.theta(np.array([0.5 * frames / fps]))[0]  # facing the scene's centre midway

    from scipy.spatial.transform import Rotation  # here: correcting never needs it

    def render(times: np.ndarray) -> np.ndarray:
        """Render the picture whose row ``y`` is read at ``times[y]`` (seconds)."""
        rot = Rotation.from_rotvec(log.theta(times) - zero).as_matrix()  # (h, 3, 3)
        d = np.einsum("yxj,yjk->yxk", homog, rot)  # R^T applied to each row's rays
        z = np.maximum(d[..., 2], 1e-6)
        mx = (s_f * d[..., 0] / z + (sw - 1) / 2.0).astype(np.float32)
        my = (s_f * d[..., 1] / z + (sh - 1) / 2.0).astype(np.float32)
        return cv2.remap(scene, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)

    out = []
    for n in range(frames):
        row_t = timing.row_times(h, float(n)) / fps
        ref_t = np.full(h, timing.reference_time(h, float(n)) / fps)
        out.append(RotatingFrame(render(row_t), render(ref_t), float(n)))
    return out, log
