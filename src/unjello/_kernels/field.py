"""Compiled passes of the dense method's field helpers: the fill, the snap, the maps.

:func:`unjello.motion.dense.field.fill_unreliable` and
:func:`~unjello.motion.dense.field.snap_to_global`
end in a chain of whole-field NumPy calls (a division, a maximum, a mask, two copies under
it; the projective flow's seven products and the four sampling maps), each writing a
temporary of the 480 x 270 working grid; where a field carries each pixel (the landing
test, the maps the inverse flow and the backward map sample at) was a broadcast sum and
four comparisons. Each is one loop here, with the same float32 operations in the same
order, so the result is the one NumPy gives, bit for bit (their references:
``tests/_kernels/test_field.py``). OpenCV keeps what it does in one vectorised call (the
resampling, the blurs, the patch sums, the pick of the cheaper patch).

Compiled as :mod:`unjello._kernels.pixelwise` is (:func:`unjello._kernels.jit.compiled`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .jit import compiled

__all__ = ["fill_from_weights", "projective_maps", "grid_plus", "lands_inside", "fixed_point_maps",
           "map_rows", "outside_in_rows"]


def fill_from_weights(resid: np.ndarray, ok: np.ndarray, num: np.ndarray, weight: np.ndarray,
                      prior: np.ndarray | None, prior_below: float) -> np.ndarray:
    """Return the average ``num / weight`` where ``ok`` is not set, ``resid`` where it is.

    Where the weight is at most ``prior_below``, the ``prior`` instead; with no prior,
    0 where it is at most 1e-3 (the tail of :func:`~unjello.motion.dense.field.fill_unreliable`).

    Parameters
    ----------
    resid, num : ndarray of shape (h, w, 2), float32
        The field, and the blurred sum of its reliable vectors.
    ok : ndarray of bool, shape (h, w)
    weight : ndarray of shape (h, w), float32
        The blurred share of reliable pixels.
    prior : ndarray of shape (h, 1, 2) or (h, w, 2), float32, optional
    prior_below : float

    Returns
    -------
    ndarray of shape (h, w, 2), float32
    """
    out = np.empty_like(num)
    has = prior is not None
    _fill_from_weights(resid, ok, num, weight, prior if has else np.zeros((1, 1, 2), np.float32),
                       has, np.float32(prior_below), out)
    return out


@compiled
def _fill_from_weights(resid: np.ndarray, ok: np.ndarray, num: np.ndarray, weight: np.ndarray,
                       prior: np.ndarray, has_prior: bool, below: np.float32, out: np.ndarray
                       ) -> None:
    h, w = ok.shape
    floor = np.float32(1e-3)
    zero = np.float32(0.0)
    wide = prior.shape[1] > 1
    for i in range(h):
        for j in range(w):
            if ok[i, j]:
                out[i, j, 0] = resid[i, j, 0]
                out[i, j, 1] = resid[i, j, 1]
                continue
            wt = weight[i, j]
            if has_prior:
                if wt <= below:
                    k = j if wide else 0
                    out[i, j, 0] = prior[i, k, 0]
                    out[i, j, 1] = prior[i, k, 1]
                    continue
            elif wt <= floor:
                out[i, j, 0] = zero
                out[i, j, 1] = zero
                continue
            d = max(wt, floor)
            out[i, j, 0] = num[i, j, 0] / d
            out[i, j, 1] = num[i, j, 1] / d


def projective_maps(coef: np.ndarray, flow: np.ndarray
                    ) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray],
                               tuple[np.ndarray, np.ndarray]]:
    """Evaluate the projective flow on the pixel grid, with both fields' sampling maps.

    The model of :func:`~unjello.motion.dense.field.projective_flow` at every pixel ``(x, y)``
    of ``flow``'s grid, and where it and ``flow`` carry each pixel (``x + u``, ``y + v``:
    the maps :func:`cv2.remap` samples the other frame at).

    Parameters
    ----------
    coef : ndarray of shape (8,)
        The model's coefficients (:func:`~unjello.motion.dense.field.fit_projective`).
    flow : ndarray of shape (h, w, 2), float32

    Returns
    -------
    glob : ndarray of shape (h, w, 2), float32
    glob_maps, flow_maps : tuple of two ndarray of shape (h, w), float32
    """
    h, w = flow.shape[:2]
    glob = np.empty((h, w, 2), np.float32)
    maps = np.empty((4, h, w), np.float32)
    scale = np.float32(1.0 / max(h, w))
    _projective_maps(np.asarray(coef, np.float32), np.ascontiguousarray(flow, np.float32),
                     np.float32(0.5 * w), np.float32(0.5 * h), scale, glob, maps)
    return glob, (maps[0], maps[1]), (maps[2], maps[3])


@compiled
def _projective_maps(a: np.ndarray, flow: np.ndarray, cx: np.float32, cy: np.float32,
                     scale: np.float32, glob: np.ndarray, maps: np.ndarray) -> None:
    h, w = flow.shape[0], flow.shape[1]
    for i in range(h):
        gy = np.float32(i)
        y = (gy - cy) * scale
        for j in range(w):
            gx = np.float32(j)
            x = (gx - cx) * scale
            quad = a[6] * x + a[7] * y
            u = a[0] + a[1] * x + a[2] * y + quad * x
            v = a[3] + a[4] * x + a[5] * y + quad * y
            glob[i, j, 0] = u
            glob[i, j, 1] = v
            maps[0, i, j] = gx + u
            maps[1, i, j] = gy + v
            maps[2, i, j] = gx + flow[i, j, 0]
            maps[3, i, j] = gy + flow[i, j, 1]


def grid_plus(field: np.ndarray, top: int = 0, left: int = 0,
              out: tuple[np.ndarray, np.ndarray] | None = None
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where each pixel of a block at ``(top, left)`` lands, moved by ``field``; whether inside.

    ``x + u`` and ``y + v`` for pixel ``(x, y)`` (float32, as NumPy adds the coordinate
    grid), and whether that lies within ``0 .. w - 1``, ``0 .. h - 1`` (the frame, for a
    block that is the whole frame).

    Parameters
    ----------
    field : ndarray of shape (h, w, 2), float32
    top, left : int
        The block's first row and column in the frame.
    out : tuple of two ndarray of shape (h, w), float32, optional
        Where to write the positions.

    Returns
    -------
    x, y : ndarray of shape (h, w), float32
    inside : ndarray of bool, shape (h, w)
    """
    h, w = field.shape[:2]
    mx, my = out if out is not None else (np.empty((h, w), np.float32),
                                          np.empty((h, w), np.float32))
    inside = np.empty((h, w), np.bool_)
    _grid_plus(np.ascontiguousarray(field, np.float32), top, left, mx, my, inside)
    return mx, my, inside


@compiled
def _grid_plus(field: np.ndarray, top: int, left: int, mx: np.ndarray, my: np.ndarray,
               inside: np.ndarray) -> None:
    h, w = inside.shape
    right, bottom = np.float32(w - 1), np.float32(h - 1)
    zero = np.float32(0.0)
    for i in range(h):
        y0 = np.float32(top + i)
        for j in range(w):
            x = np.float32(left + j) + field[i, j, 0]
            y = y0 + field[i, j, 1]
            mx[i, j] = x
            my[i, j] = y
            inside[i, j] = zero <= x <= right and zero <= y <= bottom


def lands_inside(field: np.ndarray) -> np.ndarray:
    """Whether each pixel moved by ``field`` lands within the frame: :func:`grid_plus`'s test.

    The same float32 sums, without writing the positions (a third of the memory traffic).
    """
    inside = np.empty(field.shape[:2], np.bool_)
    _lands_inside(np.ascontiguousarray(field, np.float32), inside)
    return inside


@compiled
def _lands_inside(field: np.ndarray, inside: np.ndarray) -> None:
    h, w = inside.shape
    right, bottom = np.float32(w - 1), np.float32(h - 1)
    zero = np.float32(0.0)
    for i in range(h):
        y0 = np.float32(i)
        for j in range(w):
            x = np.float32(j) + field[i, j, 0]
            y = y0 + field[i, j, 1]
            inside[i, j] = zero <= x <= right and zero <= y <= bottom


def fixed_point_maps(field: np.ndarray, iterations: int, tol: float
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Each pixel's fixed point ``s = p + field(s)``, by iteration from ``s = p + field(p)``.

    ``field`` is sampled bilinearly, the position clamped to the grid (OpenCV's
    ``INTER_LINEAR`` with ``BORDER_REPLICATE``, without its 1/32-pixel quantisation of
    the position). A pixel stops once a step moves it less than ``tol`` (either axis), or
    after ``iterations`` steps (where the field folds, it does not converge).

    Parameters
    ----------
    field : ndarray of shape (h, w, 2), float32
    iterations : int
    tol : float

    Returns
    -------
    map_x, map_y : ndarray of shape (h, w), float32
    """
    h, w = field.shape[:2]
    mx, my = np.empty((h, w), np.float32), np.empty((h, w), np.float32)
    _fixed_point_maps(np.ascontiguousarray(field, np.float32), iterations, np.float32(tol),
                      mx, my)
    return mx, my


@compiled
def _fixed_point_maps(f: np.ndarray, iterations: int, tol: np.float32, mx: np.ndarray,
                      my: np.ndarray) -> None:
    h, w = f.shape[0], f.shape[1]
    right, bottom = np.float32(w - 1), np.float32(h - 1)
    zero, one = np.float32(0.0), np.float32(1.0)
    for i in range(h):
        py = np.float32(i)
        for j in range(w):
            px = np.float32(j)
            sx, sy = px + f[i, j, 0], py + f[i, j, 1]
            for _ in range(iterations):
                cx = sx if sx >= zero else zero  # (NaN: 0)
                cy = sy if sy >= zero else zero
                cx = cx if cx <= right else right
                cy = cy if cy <= bottom else bottom
                x0, y0 = int(cx), int(cy)
                x1, y1 = min(x0 + 1, w - 1), min(y0 + 1, h - 1)
                ax, ay = cx - np.float32(x0), cy - np.float32(y0)
                bx, by = one - ax, one - ay
                nx = px + ((f[y0, x0, 0] * bx + f[y0, x1, 0] * ax) * by
                           + (f[y1, x0, 0] * bx + f[y1, x1, 0] * ax) * ay)
                ny = py + ((f[y0, x0, 1] * bx + f[y0, x1, 1] * ax) * by
                           + (f[y1, x0, 1] * bx + f[y1, x1, 1] * ax) * ay)
                moved = max(abs(nx - sx), abs(ny - sy))
                sx, sy = nx, ny
                if moved < tol:
                    break
            mx[i, j], my[i, j] = sx, sy


@njit(inline="always")
def _between(rows: np.ndarray, k: int, f: np.float32, g: np.float32, x: int) -> np.float32:
    """Row ``k`` and ``k + 1`` of ``rows`` at column ``x``, weighted ``g`` and ``f``."""
    return g * rows[k, x] + f * rows[k + 1, x]


def map_rows(rows: np.ndarray, top: np.ndarray, frac: np.ndarray, held: np.ndarray,
             first: int, last: int, out: np.ndarray) -> None:
    """Interpolate a map along y: plane rows ``first:last`` into ``out`` (float32).

    ``out[i] = (1 - f) * rows[k] + f * rows[k + 1] + held[y]`` for plane row ``y = first +
    i``, with ``k = top[y]`` and ``f = frac[y]`` (:class:`unjello.warp.bands.PlaneMaps`).

    Parameters
    ----------
    rows : ndarray of shape (hc, width), float32
        The coarse grid's rows, interpolated along x to the plane's width.
    top : ndarray of int64, shape (height,)
    frac, held : ndarray of float32, shape (height,)
    first, last : int
    out : ndarray of shape (>= last - first, width), float32
    """
    _map_rows(rows, top, frac, held, first, last, out)


@compiled
def _map_rows(rows: np.ndarray, top: np.ndarray, frac: np.ndarray, held: np.ndarray,
              first: int, last: int, out: np.ndarray) -> None:
    one = np.float32(1.0)
    for y in range(first, last):
        k, f, add = top[y], frac[y], held[y]
        g = one - f
        for x in range(rows.shape[1]):
            out[y - first, x] = _between(rows, k, f, g, x) + add


def outside_in_rows(cells: np.ndarray, rows_x: np.ndarray, rows_y: np.ndarray,
                    top: np.ndarray, frac: np.ndarray, held: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Find the pixels whose source lies outside the plane, only in the marked cells.

    The maps are :func:`map_rows`' of ``rows_x`` (nothing held) and ``rows_y`` (``held``
    added), evaluated only in the cells marked in ``cells`` (th, tw): pixel ``(x, y)`` of
    the (height, width) plane belongs to cell ``(x * tw // width, y * th // height)`` (as
    nearest-neighbour upsampling of ``cells`` would say). Row by row, as
    ``cv2.findNonZero`` lists them.

    Returns
    -------
    xs, ys : ndarray of int32
        The pixels whose source lies more than half a pixel outside.
    sx, sy : ndarray of float32
        Their sources.
    """
    w = rows_x.shape[1]
    tw = cells.shape[1]
    c = np.arange(tw + 1, dtype=np.int64)
    lo = (c * w + tw - 1) // tw  # the first pixel column of each cell
    found = [np.empty(0, np.int32), np.empty(0, np.int32), np.empty(0, np.float32),
             np.empty(0, np.float32)]
    args = (np.ascontiguousarray(cells, np.uint8), rows_x, rows_y, top, frac, held, lo)
    count = _outside_in_rows(*args, *found, False)  # count, then fill
    found = [np.empty(count, a.dtype) for a in found]
    _outside_in_rows(*args, *found, True)
    xs, ys, sx, sy = found
    return xs, ys, sx, sy


@compiled
def _outside_in_rows(cells: np.ndarray, rows_x: np.ndarray, rows_y: np.ndarray,
                     top: np.ndarray, frac: np.ndarray, held: np.ndarray, lo: np.ndarray,
                     xs: np.ndarray, ys: np.ndarray, sx: np.ndarray, sy: np.ndarray,
                     fill: bool) -> int:
    h, w = top.shape[0], rows_x.shape[1]
    th, tw = cells.shape
    one, zero = np.float32(1.0), np.float32(0.0)
    n = 0
    for y in range(h):
        cy = y * th // h
        k, f = top[y], frac[y]
        g = one - f
        for c in range(tw):
            if not cells[cy, c]:
                continue
            for x in range(lo[c], lo[c + 1]):
                px = _between(rows_x, k, f, g, x) + zero
                py = _between(rows_y, k, f, g, x) + held[y]
                if px < -0.5 or px > w - 0.5 or py < -0.5 or py > h - 0.5:
                    if fill:
                        xs[n], ys[n], sx[n], sy[n] = x, y, px, py
                    n += 1
    return n
