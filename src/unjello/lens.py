"""One lens model: a pinhole or OpenCV's fisheye, its camera matrix, points and maps.

The camera matrix of a frame of ``h x w`` pixels has the focal length on its diagonal and
its centre in the middle of the frame, ``((w - 1) / 2, (h - 1) / 2)``. A fisheye lens
bends the rays by OpenCV's model (``k1 .. k4``, as in Gyroflow's lens profiles):
:meth:`Lens.undistort` takes pixels to the rays they saw (``z = 1``), :meth:`Lens.distort`
takes rays back to pixels. The gyro method rotates the undistorted rays, the warper takes
a fisheye picture to a pinhole one of the same focal length, and the lens simulator
renders a world through it, all with this one model.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["Lens"]


@dataclass(frozen=True)
class Lens:
    """A lens: its focal length in pixels and, for a fisheye, its distortion.

    Parameters
    ----------
    focal : float
        Focal length in pixels of the frame it is used on.
    k : tuple of 4 float, optional
        Fisheye distortion ``k1 .. k4`` (OpenCV's model); None: a pinhole.

    Examples
    --------
    >>> lens = Lens(100.0, (0.05, 0.0, 0.0, 0.0))
    >>> rays = lens.undistort(np.array([[90.0, 20.0]]), (41, 61))
    >>> np.round(lens.distort(rays, (41, 61)), 6).tolist()
    [[90.0, 20.0]]
    """

    focal: float
    k: tuple[float, ...] | None = None

    def matrix(self, size: tuple[int, int]) -> np.ndarray:
        """Return the camera matrix for a frame of ``size = (h, w)``."""
        h, w = size
        f = self.focal
        return np.array([[f, 0, (w - 1) / 2.0], [0, f, (h - 1) / 2.0], [0, 0, 1.0]])

    def _coef(self) -> np.ndarray:
        return np.asarray(self.k, dtype=np.float64)

    def undistort(self, points: np.ndarray, size: tuple[int, int]) -> np.ndarray:
        """Return the rays ``(x, y)`` (``z = 1``) that pixels ``points`` (..., 2) saw."""
        pts = np.ascontiguousarray(points, dtype=np.float64)  # OpenCV reads the buffer
        flat = pts.reshape(-1, 1, 2)
        cam = self.matrix(size)
        rays = (cv2.undistortPoints(flat, cam, None) if self.k is None
                else cv2.fisheye.undistortPoints(flat, cam, self._coef()))
        return rays.reshape(pts.shape)

    def distort(self, rays: np.ndarray, size: tuple[int, int]) -> np.ndarray:
        """Return the pixels where rays ``(x, y)`` (``z = 1``, shape (..., 2)) are seen."""
        r = np.ascontiguousarray(rays, dtype=np.float64)
        cam = self.matrix(size)
        if self.k is None:
            return r * self.focal + cam[:2, 2]
        return cv2.fisheye.distortPoints(r.reshape(-1, 1, 2), cam,
                                         self._coef()).reshape(r.shape)

    def undistortion_maps(self, size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
        """Backward maps from a pinhole picture to the fisheye picture it is taken from.

        Output pixel ``o`` of an ``h x w`` picture with this focal length, its centre in
        the middle, is read at ``distort(K^-1 o)``. A fisheye sees more than the pinhole
        of its focal length, so every output pixel has a source.
        """
        h, w = size
        cam = self.matrix(size)
        gx, gy = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
        rays = np.stack([(gx - cam[0, 2]) / self.focal, (gy - cam[1, 2]) / self.focal],
                        axis=-1)
        src = self.distort(rays, size).astype(np.float32)
        return np.ascontiguousarray(src[..., 0]), np.ascontiguousarray(src[..., 1])

    def scaled(self, factor: float) -> Lens:
        """Return the lens for a plane ``factor`` times the frame's size (chroma)."""
        return Lens(self.focal * factor, self.k)
