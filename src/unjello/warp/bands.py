"""A per-pixel motion's backward maps at a plane's size, made a band of rows at a time.

The dense method's backward maps come on its field's grid (480 x 270 for a 1080p frame)
and every plane needs them at its own size. Upsampled whole (:func:`cv2.resize`), a
1080p frame's two float32 maps are 16 MB, written out and read back by the remap through
main memory (a 4K frame's 66 MB, held all run). :class:`PlaneMaps` interpolates along x
once (the grid's rows at the plane's width) and along y a band of rows at a time:
:func:`warp_bands` remaps each band while its maps are still in the cache, and the pixels
whose source leaves the frame are found from the same rows (:meth:`PlaneMaps.outside`),
so no whole-plane map is made. Bilinear as :func:`cv2.resize` is, pixel centres aligned;
beyond the outermost samples the displacement is held (:meth:`PlaneMaps.whole`).
"""

from __future__ import annotations

import cv2
import numpy as np

from .._kernels.field import map_rows, outside_in_rows

__all__ = ["PlaneMaps", "warp_bands", "band_rows", "BAND_SAMPLES"]

#: Map samples in a band (its rows times the plane's width): both maps of a band take 2 x 4 bytes a
#: sample, 0.5 MB, within a core's cache. (``docs/tuning.md#band_samples``)
BAND_SAMPLES = 1 << 16


def band_rows(height: int, width: int) -> int:
    """Return the rows of a band of a ``height x width`` plane (:data:`BAND_SAMPLES`)."""
    return min(height, max(1, BAND_SAMPLES // width))


def _held_beyond(size: int, n: int, scale: float) -> np.ndarray:
    """Per plane pixel along one axis: how far beyond the outermost sample centres it lies.

    In plane pixels (0 between the centres): bilinear interpolation holds the value
    there, so the source position would stop moving and smear the edge over half a
    sample (4 px for a field every 8 px); adding this holds the displacement instead.
    """
    coarse = (np.arange(size, dtype=np.float32) + np.float32(0.5)) / np.float32(scale) \
        - np.float32(0.5)
    return ((coarse - np.clip(coarse, 0, n - 1)) * np.float32(scale)).astype(np.float32)


class PlaneMaps:
    """Backward maps on a coarse grid, taken to a plane of ``height x width`` row by row.

    Parameters
    ----------
    map_x, map_y : ndarray of shape (h, w), float32
        Source positions in pixels of the coarse grid (pixel centres at integers).
    height, width : int
        The plane's size.

    Attributes
    ----------
    coarse : tuple of ndarray
        The maps given.
    shape : tuple of int
        ``(height, width)``.
    """

    def __init__(self, map_x: np.ndarray, map_y: np.ndarray, height: int, width: int) -> None:
        h, w = map_x.shape
        self.coarse = (map_x, map_y)
        self.shape = (height, width)
        sx, sy = np.float32(width / w), np.float32(height / h)
        # Linear interpolation commutes with the affine change of units: first, on the
        # coarse maps; then along x, once, for every coarse row (cv2.resize).
        rows_x, rows_y = (np.ascontiguousarray(cv2.resize(
            (np.asarray(m, np.float32) + np.float32(0.5)) * s - np.float32(0.5), (width, h),
            interpolation=cv2.INTER_LINEAR).reshape(h, width))
            for m, s in ((map_x, sx), (map_y, sy)))
        rows_x += _held_beyond(width, w, float(sx))[None, :]
        if h == 1:  # one coarse row: both taps on it
            rows_x, rows_y = np.repeat(rows_x, 2, axis=0), np.repeat(rows_y, 2, axis=0)
        self._rows = (rows_x, rows_y)
        centre = (np.arange(height, dtype=np.float64) + 0.5) * (h / height) - 0.5
        self._top = np.clip(np.floor(centre), 0, max(h - 2, 0)).astype(np.int64)
        self._frac = np.clip(centre - self._top, 0.0, 1.0).astype(np.float32)
        self._held_y = _held_beyond(height, h, float(sy))
        self._zero = np.zeros(height, np.float32)

    def band(self, top: int, bottom: int, out: tuple[np.ndarray, np.ndarray] | None = None
             ) -> tuple[np.ndarray, np.ndarray]:
        """Both maps for the plane's rows ``top:bottom`` (into ``out``'s first rows)."""
        n, width = bottom - top, self.shape[1]
        if out is None:
            out = (np.empty((n, width), np.float32), np.empty((n, width), np.float32))
        mx, my = out[0][:n], out[1][:n]
        for rows, held, dst in ((self._rows[0], self._zero, mx), (self._rows[1], self._held_y, my)):
            map_rows(rows, self._top, self._frac, held, top, bottom, dst)
        return mx, my

    def whole(self, out: tuple[np.ndarray, np.ndarray] | None = None
              ) -> tuple[np.ndarray, np.ndarray]:
        """Both maps for the whole plane (a lens composed with them, an export)."""
        return self.band(0, self.shape[0], out)

    def outside(self, cells: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Find the pixels whose source lies outside the plane, in the marked cells only.

        ``cells`` (th, tw) marks the coarse samples near which a source may leave;
        pixel ``(x, y)`` belongs to cell ``(x * tw // width, y * th // height)``. Row by
        row, as :func:`cv2.findNonZero` lists them; their sources are the maps'
        (:meth:`band`), bit for bit.

        Returns
        -------
        xs, ys : ndarray of int32
        sx, sy : ndarray of float32
        """
        return outside_in_rows(cells, *self._rows, self._top, self._frac, self._held_y)

    def sample(self, step: int) -> tuple[np.ndarray, np.ndarray]:
        """Both maps at every ``step``-th pixel of every ``step``-th row (from ``step // 2``)."""
        height, width = self.shape
        rows = np.arange(step // 2, height, step)
        cols = slice(step // 2, None, step)
        out = []
        for grid, held in ((self._rows[0], self._zero), (self._rows[1], self._held_y)):
            f = self._frac[rows, None]
            top = grid[self._top[rows], cols]
            out.append(np.ascontiguousarray(
                (np.float32(1) - f) * top + f * grid[self._top[rows] + 1, cols] + held[rows, None],
                np.float32))
        return out[0], out[1]


def warp_bands(image: np.ndarray, maps: PlaneMaps, fill: str = "nearest",
               buffers: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Backward warp ``out(p) = image(maps(p))``, bilinear (:func:`cv2.remap`), band by band.

    Parameters
    ----------
    image : ndarray of shape (h, w[, c])
    maps : PlaneMaps
        Of the plane's size.
    fill : {'nearest', 'black'}
        What to put where the source lies outside the image.
    buffers : tuple of ndarray, optional
        Two float32 arrays of at least a band's rows x the plane's width, reused.
    """
    height, width = maps.shape
    rows = band_rows(height, width)
    if buffers is None or buffers[0].shape[0] < rows:
        buffers = (np.empty((rows, width), np.float32), np.empty((rows, width), np.float32))
    border = cv2.BORDER_REPLICATE if fill == "nearest" else cv2.BORDER_CONSTANT
    out = np.empty_like(image)
    for top in range(0, height, rows):
        bottom = min(height, top + rows)
        mx, my = maps.band(top, bottom, buffers)
        cv2.remap(image, mx, my, cv2.INTER_LINEAR, dst=out[top:bottom], borderMode=border,
                  borderValue=0)
    return out
