"""Backward warps band by band, from maps that are never written whole.

A backward warp (:func:`cv2.remap`) reads two float maps the size of the plane: 16 MB for a
1080p luma plane, 64 MB at 4K. Written whole and then read, in a real run with the
decoder and the encoder using the caches too, that memory traffic cost as much as the
interpolation (``docs/measurements.md``). Here the maps are made a band of rows at a time
(32 K samples, both maps held in the core's cache) and each band is remapped into the
output: the same maps, the same sampling, a fraction of the memory.

- :func:`remap_coarse`: the dense method's maps, on its working grid (480 px wide by
  default), upsampled along x once per coarse row and along y band by band;
  :func:`coarse_at` gives them at chosen pixels.
- :func:`remap_scanlines`: a per-scanline displacement (eq. 26), one source row and
  one shift per output row.

``tests/test_band_remap.py`` compares both with the whole maps of :mod:`unjello.warp`.
"""

from __future__ import annotations

from collections.abc import Callable

import cv2
import numpy as np

__all__ = ["remap_coarse", "coarse_at", "remap_scanlines"]

#: Map samples per band (both maps in float32: 256 KB, held in the core's cache).
_BAND = 32768


def _axis(n_out: int, n_coarse: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per output pixel along one axis: lower coarse index, the upper one's weight, beyond.

    Pixel centres line up (``u = (X + 0.5) n_coarse / n_out - 0.5``), as ``cv2.resize``;
    beyond the outermost coarse centres the position is held and ``beyond`` (in coarse
    samples) says how far past it the pixel lies.
    """
    u = (np.arange(n_out) + 0.5) * (n_coarse / n_out) - 0.5
    uc = np.clip(u, 0.0, n_coarse - 1.0)
    lo = np.minimum(np.floor(uc).astype(np.int64), max(n_coarse - 2, 0))
    frac = (uc - lo) if n_coarse > 1 else np.zeros(n_out)
    return lo, frac.astype(np.float32), (u - uc).astype(np.float32)


def _banded(image: np.ndarray, band: Callable[[int, np.ndarray, np.ndarray], None],
            fill: str) -> np.ndarray:
    """Remap ``image`` band by band; ``band(lo, bx, by)`` fills the maps of rows ``lo ..``."""
    h, w = image.shape[:2]
    out = np.empty_like(image)
    rows = max(1, _BAND // w)
    bx, by = np.empty((rows, w), np.float32), np.empty((rows, w), np.float32)
    border = cv2.BORDER_REPLICATE if fill == "nearest" else cv2.BORDER_CONSTANT
    for lo in range(0, h, rows):
        n = min(rows, h - lo)
        band(lo, bx[:n], by[:n])
        cv2.remap(image, bx[:n], by[:n], cv2.INTER_LINEAR, dst=out[lo:lo + n],
                  borderMode=border, borderValue=0)
    return out


def remap_scanlines(image: np.ndarray, dx: np.ndarray, sy: np.ndarray, fill: str = "nearest"
                    ) -> np.ndarray:
    """Backward warp of a per-scanline displacement: output row ``y`` reads row ``sy[y]``.

    Equal to ``apply_maps(image, remap_maps(...))`` of :mod:`unjello.warp`, band by band.

    Parameters
    ----------
    image : ndarray of shape (h, w[, c])
    dx, sy : ndarray of shape (h,)
        Each output row's source row and its shift along x
        (:func:`~unjello.warp.scanline_sources`).
    fill : {'nearest', 'black'}

    Examples
    --------
    >>> img = np.tile(np.arange(6, dtype=np.uint8), (3, 1))
    >>> remap_scanlines(img, np.float32([0, 1, 2]), np.float32([0, 1, 2]))[2].tolist()
    [2, 3, 4, 5, 5, 5]
    """
    w = image.shape[1]
    cols = np.arange(w, dtype=np.float32)
    dx = np.asarray(dx, np.float32)
    sy = np.asarray(sy, np.float32)

    def band(lo: int, bx: np.ndarray, by: np.ndarray) -> None:
        n = bx.shape[0]
        np.add(cols[None, :], dx[lo:lo + n, None], out=bx)
        by[...] = sy[lo:lo + n, None]

    return _banded(np.ascontiguousarray(image), band, fill)


def remap_coarse(image: np.ndarray, maps: tuple[np.ndarray, np.ndarray],
                 fill: str = "nearest") -> np.ndarray:
    """Backward warp of ``image`` by coarse maps, upsampled on the fly to its size.

    Equal to ``apply_maps(image, resize_maps(*maps, h, w), fill)`` of :mod:`unjello.warp`
    up to the last bit of a map value (at most one grey level, rarely), without the
    full-size maps.

    Parameters
    ----------
    image : ndarray of shape (h, w[, c]), uint8, uint16 or float32
        A plane (top-bottom).
    maps : tuple of ndarray of shape (gh, gw), float32
        Source x and y of every grid sample, in pixels of the grid (as
        :func:`~unjello.warp.field_maps` gives them).
    fill : {'nearest', 'black'}
        What to put where the source lies outside the plane.

    Returns
    -------
    ndarray like ``image``

    Examples
    --------
    A grid of 2 x 3 samples that reads every pixel one grid step (4 px) to its right:

    >>> img = np.tile(np.arange(12, dtype=np.uint8), (8, 1))
    >>> gx = np.tile(np.arange(3, dtype=np.float32) + 1, (2, 1))
    >>> gy = np.tile(np.arange(2, dtype=np.float32)[:, None], (1, 3))
    >>> remap_coarse(img, (gx, gy))[0].tolist()
    [4, 5, 6, 7, 8, 9, 10, 11, 11, 11, 11, 11]
    """
    img = np.ascontiguousarray(image)
    if img.dtype not in (np.uint8, np.uint16, np.float32):
        img = img.astype(np.float32)
    h, w = img.shape[:2]
    gh, gw = maps[0].shape
    sx, sy = np.float32(w / gw), np.float32(h / gh)
    # Along x first, once per coarse row (pixel centres aligned; the edges held).
    wide_x, wide_y = (cv2.resize(np.asarray(m, np.float32), (w, gh),
                                 interpolation=cv2.INTER_LINEAR) for m in maps)
    col_b = _axis(w, gw)[2]
    cols = ((col_b + np.float32(0.5)) * sx - np.float32(0.5), sx)
    row_lo, row_f, row_b = _axis(h, gh)
    row_hi = np.minimum(row_lo + 1, gh - 1)
    off_y = (row_b + np.float32(0.5)) * sy - np.float32(0.5)

    def band(lo: int, bx: np.ndarray, by: np.ndarray) -> None:
        """Rows ``lo ..`` of the maps: the two x-upsampled coarse rows around each, blended."""
        rows = slice(lo, lo + bx.shape[0])
        fv = row_f[rows, None]
        for out, wide, scale, off in ((bx, wide_x, sx, cols[0][None, :]),
                                      (by, wide_y, sy, off_y[rows, None])):
            top = wide[row_lo[rows]]
            np.subtract(wide[row_hi[rows]], top, out=out)
            out *= fv
            out += top
            out *= scale
            out += off

    return _banded(img, band, fill)


def coarse_at(maps: tuple[np.ndarray, np.ndarray], size: tuple[int, int], ys: np.ndarray,
              xs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return the coarse maps upsampled to ``size`` (h, w), at the pixels ``(ys, xs)`` only.

    The positions :func:`remap_coarse` samples there (:func:`~unjello.warp.resize_maps`
    at those pixels): for a few pixels, such as those whose source lies outside the frame.
    """
    h, w = size
    gh, gw = maps[0].shape
    c0, fu, bx = (a[xs] for a in _axis(w, gw))
    r0, fv, by = (a[ys] for a in _axis(h, gh))
    c1, r1 = np.minimum(c0 + 1, gw - 1), np.minimum(r0 + 1, gh - 1)
    out = []
    for m, s, beyond in ((maps[0], np.float32(w / gw), bx), (maps[1], np.float32(h / gh), by)):
        left = m[r0, c0] + fv * (m[r1, c0] - m[r0, c0])  # rows first, as the kernel
        right = m[r0, c1] + fv * (m[r1, c1] - m[r0, c1])
        out.append((left + fu * (right - left) + np.float32(0.5)) * s - np.float32(0.5)
                   + beyond * s)
    return out[0], out[1]
