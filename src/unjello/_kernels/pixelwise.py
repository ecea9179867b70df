"""Compiled per-pixel kernels: the dense method's checks, residuals and fits in one pass each.

The stages after the optical flow combine a flow field with the camera's motion pixel by
pixel. In NumPy each step is a whole-field call writing a temporary (a sum, a norm, a
comparison, a sort): on the 480 x 270 working grid the memory traffic and the calls cost
more than the arithmetic. Here each job is one loop over the grid (Numba, ``njit`` with
``cache=True``: compiled once on first use, about 5.5 s with :mod:`unjello._kernels.field`'s
and :mod:`unjello._kernels.drift`'s, then loaded from the cache next to this file or,
where that is read-only, Numba's user-wide cache; with no writable cache anywhere,
compiled every run). Where OpenCV does a job in one vectorised call (resampling
a smooth field at moved positions) it stays: compiled loops of those were slower
(``docs/history/measurements.md``).

Bilinear sampling clamps the position to the grid, which is OpenCV's ``INTER_LINEAR`` with
``BORDER_REPLICATE`` without its 1/32-pixel quantisation of the position. Each kernel has
a NumPy (or OpenCV) reference in ``tests/_kernels/test_pixelwise.py`` or
``tests/warp/test_scanlines.py``;
they agree within 1e-3 px (one grey level for the warp).

Arrays in, arrays out; float32 fields of shape (h, w, 2), C-contiguous.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from . import drift as kernels_drift
from . import field as kernels_field
from .jit import compiled

__all__ = ["consistency", "residual_side", "quadratic_ahead", "jacobian_det",
           "shift_rows", "shorth_sorted", "warm_up"]


@njit(inline="always")
def _clamp(v: float, hi: float) -> float:
    if not v >= 0.0:  # also NaN
        return 0.0
    return hi if v > hi else v


def consistency(fwd: np.ndarray, bwd: np.ndarray, tol: float) -> np.ndarray:
    """Pixels whose flow ``fwd`` lands inside the frame and ``bwd`` brings back within ``tol``.

    Returns
    -------
    ndarray of bool, shape (h, w)
    """
    ok = np.zeros(fwd.shape[:2], np.bool_)
    _consistency(fwd, bwd, tol, ok)
    return ok


@compiled
def _consistency(fwd: np.ndarray, bwd: np.ndarray, tol: float, ok: np.ndarray) -> None:
    # In float32 throughout, as the flows (1.5x faster than the same loop in float64).
    h, w = fwd.shape[0], fwd.shape[1]
    tol2 = np.float32(tol * tol)
    right, bottom = np.float32(w - 1), np.float32(h - 1)
    one = np.float32(1.0)
    for i in range(h):
        yi = np.float32(i)
        for j in range(w):
            # Where it lands (a landing on the last row stays on it).
            fx, fy = fwd[i, j, 0], fwd[i, j, 1]
            x, y = np.float32(j) + fx, yi + fy
            if not (x >= 0.0 and x <= right and y >= 0.0 and y <= bottom):
                continue
            x0, y0 = int(x), int(y)
            x1, y1 = min(x0 + 1, w - 1), min(y0 + 1, h - 1)
            ax, ay = x - np.float32(x0), y - np.float32(y0)
            bx, by = one - ax, one - ay
            u = ((bwd[y0, x0, 0] * bx + bwd[y0, x1, 0] * ax) * by
                 + (bwd[y1, x0, 0] * bx + bwd[y1, x1, 0] * ax) * ay)
            v = ((bwd[y0, x0, 1] * bx + bwd[y0, x1, 1] * ax) * by
                 + (bwd[y1, x0, 1] * bx + bwd[y1, x1, 1] * ax) * ay)
            ok[i, j] = (fx + u) ** 2 + (fy + v) ** 2 <= tol2


def residual_side(flow: np.ndarray, cam: np.ndarray, grid_t0: float, step: float,
                  other_start: float, row_time: float, t_rows: np.ndarray,
                  cam_rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Take the camera's motion over the same time off each pixel's flow (eq. 26).

    The pixel of row ``y`` lands in the neighbour on row ``y + flow_y``, read at
    ``other_start + row_time * (y + flow_y)`` (times from this frame's start); the camera
    trajectory ``cam`` (uniform grid from ``grid_t0``, ``step`` apart; held at its ends)
    there, subtracted from its value on the pixel's own row ``cam_rows``, is the camera's
    part of the flow.

    Returns
    -------
    e : ndarray of shape (h, w), float32
        The time from the pixel's own to where it lands.
    resid : ndarray of shape (h, w, 2), float32
        ``flow + cam_rows[y] - cam(t_landing)``.
    """
    e = np.empty(flow.shape[:2], np.float32)
    resid = np.empty(flow.shape, np.float32)
    _residual_side(flow, cam, grid_t0, step, other_start, row_time, t_rows, cam_rows, e, resid)
    return e, resid


@compiled
def _residual_side(flow: np.ndarray, cam: np.ndarray, grid_t0: float, step: float,
                   other_start: float, row_time: float, t_rows: np.ndarray,
                   cam_rows: np.ndarray, e: np.ndarray, resid: np.ndarray) -> None:
    h, w = flow.shape[0], flow.shape[1]
    n = cam.shape[0]
    inv_step = 1.0 / step
    for i in range(h):
        t_own = float(t_rows[i])
        cx, cy = float(cam_rows[i, 0]), float(cam_rows[i, 1])
        for j in range(w):
            fx, fy = float(flow[i, j, 0]), float(flow[i, j, 1])
            t = other_start + row_time * (i + fy)
            k = _clamp((t - grid_t0) * inv_step, n - 1.0)
            k0 = int(k)
            k1 = min(k0 + 1, n - 1)
            a = k - k0
            e[i, j] = t - t_own
            resid[i, j, 0] = fx + cx - (cam[k0, 0] * (1.0 - a) + cam[k1, 0] * a)
            resid[i, j, 1] = fy + cy - (cam[k0, 1] * (1.0 - a) + cam[k1, 1] * a)


def quadratic_ahead(ea: np.ndarray, ra: np.ndarray, oka: np.ndarray, eb: np.ndarray,
                    rb: np.ndarray, okb: np.ndarray, ahead: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Each pixel's residual at the reference time from both neighbours' (Lagrange).

    With both sides reliable, the quadratic through ``(ea, ra)``, ``(0, 0)`` and
    ``(eb, rb)`` at ``ahead``; with one, the line through it and ``(0, 0)``; with none,
    zero and the fallback set. ``ahead`` has one value a row, shape (h, 1).
    """
    field = np.zeros((*oka.shape, 2), np.float32)
    fallback = np.zeros(oka.shape, np.bool_)
    _quadratic_ahead(ea, ra, oka, eb, rb, okb, ahead, field, fallback)
    return field, fallback


@compiled
def _quadratic_ahead(ea: np.ndarray, ra: np.ndarray, oka: np.ndarray, eb: np.ndarray,
                     rb: np.ndarray, okb: np.ndarray, ahead: np.ndarray, field: np.ndarray,
                     fallback: np.ndarray) -> None:
    h, w = oka.shape
    for i in range(h):
        t = float(ahead[i, 0])
        for j in range(w):
            a, b = oka[i, j], okb[i, j]
            if a and b:
                e1, e2 = float(ea[i, j]), float(eb[i, j])
                gap = e1 - e2
                la = (t - e2) * t / (e1 * gap)
                lb = (t - e1) * t / (e2 * -gap)
                field[i, j, 0] = la * ra[i, j, 0] + lb * rb[i, j, 0]
                field[i, j, 1] = la * ra[i, j, 1] + lb * rb[i, j, 1]
            elif a:
                s = t / float(ea[i, j])
                field[i, j, 0] = s * ra[i, j, 0]
                field[i, j, 1] = s * ra[i, j, 1]
            elif b:
                s = t / float(eb[i, j])
                field[i, j, 0] = s * rb[i, j, 0]
                field[i, j, 1] = s * rb[i, j, 1]
            else:
                fallback[i, j] = True


def jacobian_det(field: np.ndarray) -> np.ndarray:
    """``det(I - grad D)`` of the map ``p = s - D(s)`` at every pixel, float32.

    Derivatives as ``np.gradient`` takes them: central differences inside, one-sided at
    the grid's edges (zero along an axis of one sample).
    """
    det = np.empty(field.shape[:2], np.float32)
    _jacobian_det(field, det)
    return det


@compiled
def _jacobian_det(field: np.ndarray, det: np.ndarray) -> None:
    h, w = field.shape[0], field.shape[1]
    for i in range(h):
        i0, i1 = max(i - 1, 0), min(i + 1, h - 1)
        dy = 1.0 / (i1 - i0) if i1 > i0 else 0.0
        for j in range(w):
            j0, j1 = max(j - 1, 0), min(j + 1, w - 1)
            dx = 1.0 / (j1 - j0) if j1 > j0 else 0.0
            dxx = (field[i, j1, 0] - field[i, j0, 0]) * dx
            dyx = (field[i, j1, 1] - field[i, j0, 1]) * dx
            dxy = (field[i1, j, 0] - field[i0, j, 0]) * dy
            dyy = (field[i1, j, 1] - field[i0, j, 1]) * dy
            det[i, j] = (1.0 - dxx) * (1.0 - dyy) - dxy * dyx


@njit(inline="always")
def _edge_tap(src: np.ndarray, j: int, black: bool) -> np.float32:
    """``src[j]``, beyond the row's ends the end repeated (or black)."""
    w = src.size
    if 0 <= j < w:
        return np.float32(src[j])
    if black:
        return np.float32(0.0)
    return np.float32(src[min(max(j, 0), w - 1)])


@njit(inline="always")
def _edge_taps(src0: np.ndarray, src1: np.ndarray, j: int, black: bool, w00: np.float32,
               w01: np.float32, w10: np.float32, w11: np.float32) -> np.float32:
    """Blend columns ``j``, ``j + 1`` of two rows bilinearly, held at their ends."""
    return (w00 * _edge_tap(src0, j, black) + w01 * _edge_tap(src0, j + 1, black)
            + w10 * _edge_tap(src1, j, black) + w11 * _edge_tap(src1, j + 1, black))


def shift_rows(image: np.ndarray, dx: np.ndarray, sy: np.ndarray, black: bool,
               top: float) -> np.ndarray:
    """Warp back by rows: ``out[y, x] = image(x + dx[y], sy[y])``, bilinear.

    What :func:`cv2.remap` does with the maps ``x + dx[y]`` and ``sy[y]``, without the
    maps: along a row the source moves by a constant, so the four weights are the row's
    own and the loop runs over two contiguous source rows, which the compiler
    vectorises. Outside the image the edge is repeated (``black`` False) or black.

    Parameters
    ----------
    image : ndarray of shape (h, w)
        Any real dtype; integers are rounded (the weights are convex: no clipping needed).
    dx, sy : ndarray of shape (h,)
        Each output row's horizontal shift and source row.
    black : bool
    top : float
        Non-zero for an integer dtype (its values are rounded); 0 for floats.

    Returns
    -------
    ndarray like ``image``
    """
    out = np.empty_like(image)
    _shift_rows(image, dx, sy, black, top, out)
    return out


@compiled
def _shift_rows(image: np.ndarray, dx: np.ndarray, sy: np.ndarray, black: bool, top: float,
                out: np.ndarray) -> None:
    h, w = image.shape
    one, half = np.float32(1.0), np.float32(0.5 if top > 0 else 0.0)
    for y in range(h):
        fy = sy[y]
        y0 = int(math.floor(fy))
        a = np.float32(fy - y0)
        v0, v1 = one - a, a
        if black and not 0 <= y0 < h:
            v0 = np.float32(0.0)
        if black and not 0 <= y0 + 1 < h:
            v1 = np.float32(0.0)
        fx = dx[y]
        ix = int(math.floor(fx))
        b = np.float32(fx - ix)
        w00, w01, w10, w11 = v0 * (one - b), v0 * b, v1 * (one - b), v1 * b
        src0, src1 = image[min(max(y0, 0), h - 1)], image[min(max(y0 + 1, 0), h - 1)]
        dst = out[y]
        # Output column x reads source columns x + ix and x + ix + 1: for x in [lo, hi)
        # both lie within the row, contiguous slices the compiler vectorises; outside it
        # the taps are held to the row's ends (or black).
        lo = min(max(-ix, 0), w)
        hi = min(max(w - 1 - ix, lo), w)
        s0, s1, d = src0[lo + ix:hi + ix + 1], src1[lo + ix:hi + ix + 1], dst[lo:hi]
        for x in range(hi - lo):
            d[x] = (w00 * np.float32(s0[x]) + w01 * np.float32(s0[x + 1])
                    + w10 * np.float32(s1[x]) + w11 * np.float32(s1[x + 1]) + half)
        for x in range(lo):
            dst[x] = _edge_taps(src0, src1, x + ix, black, w00, w01, w10, w11) + half
        for x in range(hi, w):
            dst[x] = _edge_taps(src0, src1, x + ix, black, w00, w01, w10, w11) + half


def shorth_sorted(srt: np.ndarray) -> np.ndarray:
    """Midpoint of the shortest interval holding half of each row's sorted values.

    Parameters
    ----------
    srt : ndarray of shape (rows, n, c)
        Each row's values sorted along axis 1, missing ones (NaN) last.

    Returns
    -------
    ndarray of shape (rows, c), float64
        NaN for a row with fewer than two values.
    """
    out = np.empty((srt.shape[0], srt.shape[2]), np.float64)
    _shorth_sorted(srt, out)
    return out


@compiled
def _shorth_sorted(srt: np.ndarray, out: np.ndarray) -> None:
    rows, n, c = srt.shape
    for r in range(rows):
        for k in range(c):
            valid = 0
            while valid < n and srt[r, valid, k] == srt[r, valid, k]:
                valid += 1
            half = max(valid // 2, 1)
            best, width = 0, np.inf
            for i in range(valid - half):
                d = srt[r, i + half, k] - srt[r, i, k]
                if d < width:
                    best, width = i, d
            out[r, k] = 0.5 * (srt[r, best, k] + srt[r, min(best + half, n - 1), k])


def warm_up() -> float:
    """Compile (or load from the cache) every kernel on a tiny grid.

    Returns
    -------
    float
        The CPU seconds it took (the compiler runs on one thread, so on an idle machine
        the wall time; CPU time does not count what other processes take meanwhile).
    """
    import time

    t = time.process_time()
    f = np.zeros((4, 5, 2), np.float32)
    ok = np.ones((4, 5), np.bool_)
    e = np.ones((4, 5), np.float32)
    rows = np.zeros(4, np.float32)
    consistency(f, f, 1.0)
    residual_side(f, np.zeros((3, 2), np.float32), 0.0, 1.0, 1.0, 0.1, rows,
                  np.zeros((4, 2), np.float32))
    quadratic_ahead(e, f, ok, -e, f, ok, np.zeros((4, 1), np.float32))
    shorth_sorted(np.sort(f, axis=1))
    jacobian_det(f)
    shift_rows(np.zeros((4, 5), np.uint8), np.zeros(4), np.zeros(4), False, 255.0)
    kernels_field.fill_from_weights(f, ok, f, e, f[:, :1], 0.05)
    kernels_field.projective_maps(np.zeros(8), f)
    kernels_field.grid_plus(f, 1, 2)
    kernels_field.lands_inside(f)
    kernels_field.fixed_point_maps(f, 2, 0.01)
    kernels_field.map_rows(e, np.zeros(4, np.int64), rows, rows, 0, 2, e)
    kernels_field.outside_in_rows(ok.view(np.uint8), e, e, np.zeros(4, np.int64), rows, rows)
    kernels_drift.drift_costs(np.zeros(2), [(e, 1.0)], np.ones((2, 2)), np.arange(3.0),
                              np.zeros(3, complex), 0j, (1.0, 1.0), 0j, 0.1, 2,
                              40.0)(np.zeros((1, 2)))
    return time.process_time() - t

