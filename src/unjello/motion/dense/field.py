"""The dense method's flow-field helpers: unreliable pixels, the projective field, snapping.

A flow field's unreliable pixels filled from their reliable neighbours, isolated wrong
vectors taken out, the eight-parameter projective flow (camera rotation, a plane) fitted
robustly and evaluated, each pixel's velocity carried through it, and the global motion
given back to the pixels it explains (:func:`snap_to_global`). Arrays in, arrays out:
used by :mod:`unjello.motion.dense.method`.
"""

from __future__ import annotations

import cv2
import numpy as np

from ..._kernels.field import fill_from_weights, projective_maps
from ..._kernels.pixelwise import quadratic_ahead
from ...timing import pixel_grid
from ..flow.dis import median_along
from ..flow.patches import costlier

__all__ = ["fill_unreliable", "smooth_field", "projective_flow", "fit_projective",
           "advected_velocity", "snap_to_global", "snap_to_camera", "put", "both_axes",
           "at_reference", "scale_axes", "rows_minus"]


def put(dst: np.ndarray, src: np.ndarray, where: np.ndarray) -> None:
    """Copy ``src`` into ``dst`` (in place) where the boolean ``where`` is set, per pixel.

    ``np.copyto(dst, src, where=where[..., None])`` on a (h, w, 2) field, an order of
    magnitude faster (``cv2.copyTo``: 0.07 against 1.0 ms on 480 x 270).

    Examples
    --------
    >>> dst = np.zeros((2, 3, 2), np.float32)
    >>> put(dst, np.ones_like(dst), np.array([[True, False, True], [False, False, True]]))
    >>> dst[..., 1].tolist()
    [[1.0, 0.0, 1.0], [0.0, 0.0, 1.0]]
    """
    if (src.dtype != dst.dtype or src.shape != dst.shape or not dst.flags.c_contiguous
            or dst.ndim != 3 or dst.shape[2] > 4):  # cv2 would write a new array instead
        np.copyto(dst, src, where=where[..., None] if dst.ndim == 3 else where)
        return
    cv2.copyTo(src, np.ascontiguousarray(where).view(np.uint8), dst)


def both_axes(values: np.ndarray) -> np.ndarray:
    """Return a per-pixel factor ``(h, w)`` for both axes of a field, ``(h, w, 2)``.

    Multiplying a field by ``values[..., None]`` broadcasts over an axis of two and costs
    three times as much (0.4 against 0.12 ms on 480 x 270).
    """
    return np.stack([values, values], axis=-1)


def scale_axes(field: np.ndarray, sx: float, sy: float) -> np.ndarray:
    """Multiply a field's x by ``sx`` and its y by ``sy``, in place; return it.

    ``field *= (sx, sy)`` broadcasts over an axis of two: 0.8 ms on 480 x 270, against
    0.03 ms as OpenCV's per-channel scalar.

    Examples
    --------
    >>> scale_axes(np.ones((1, 2, 2), np.float32), 2.0, 3.0)[0].tolist()
    [[2.0, 3.0], [2.0, 3.0]]
    """
    if field.dtype == np.float32 and field.flags.c_contiguous and field.ndim == 3 \
            and field.shape[2] == 2:
        cv2.multiply(field, (float(sx), float(sy), 0.0, 0.0), dst=field)
    else:
        field *= np.array([sx, sy], dtype=field.dtype)
    return field


def rows_minus(rows: np.ndarray, field: np.ndarray) -> np.ndarray:
    """Return ``rows[:, None, :] - field``: each row's ``(x, y)`` less the field's pixels.

    Without the broadcast over an axis of two (0.85 against 0.08 ms on 480 x 270).

    Examples
    --------
    >>> rows_minus(np.array([[1.0, 2.0]], np.float32), np.ones((1, 3, 2), np.float32))[0, 2]
    array([0., 1.], dtype=float32)
    """
    h, w = field.shape[:2]
    return (np.tile(np.asarray(rows, field.dtype), w)
            - np.ascontiguousarray(field).reshape(h, 2 * w)).reshape(h, w, 2)


#: Given a prior, :func:`fill_unreliable` uses it where reliable pixels weigh less than this
#: around a pixel: stray passing flow in entering content (``docs/tuning.md#prior_below``).
PRIOR_BELOW = 0.05


def fill_unreliable(resid: np.ndarray, ok: np.ndarray, sigma: float,
                    prior: np.ndarray | None = None) -> np.ndarray:
    """Replace residuals of unreliable pixels by a normalised Gaussian average of reliable ones.

    Where no reliable pixel is near (their blurred weight under 0.001: about 3
    ``sigma`` away), 0; given a ``prior`` (broadcast to ``resid``), the prior wherever
    that weight is under :data:`PRIOR_BELOW`.
    """
    if not ok.any():
        return np.zeros_like(resid) if prior is None else (
            np.broadcast_to(prior, resid.shape).astype(resid.dtype))
    if ok.all() or sigma <= 0:
        return resid
    # The average is smooth: blur at a quarter of the resolution, then interpolate back.
    h, w_ = ok.shape
    small = (max(1, w_ // 4), max(1, h // 4))
    okf = cv2.resize(ok.astype(np.float32), small, interpolation=cv2.INTER_AREA)
    kept = np.zeros_like(resid)
    put(kept, resid, ok)
    numf = cv2.resize(kept, small, interpolation=cv2.INTER_AREA)
    w = cv2.resize(cv2.GaussianBlur(okf, (0, 0), sigma / 4), (w_, h))
    num = cv2.resize(cv2.GaussianBlur(numf, (0, 0), sigma / 4), (w_, h))
    if prior is not None:
        prior = np.asarray(prior, np.float32)
        if prior.ndim != 3 or prior.shape[:2] not in ((h, 1), (h, w_)):
            prior = np.broadcast_to(prior, resid.shape)
        prior = np.ascontiguousarray(prior)
    # The average, the prior where too few reliable pixels weigh, the reliable pixels'
    # own: one compiled pass (the NumPy steps it replaces: tests/_kernels/test_field.py).
    return fill_from_weights(np.ascontiguousarray(resid, np.float32), np.ascontiguousarray(ok),
                             num, w, prior, PRIOR_BELOW)


def smooth_field(field: np.ndarray) -> np.ndarray:
    """5x5 median of each component (isolated wrong flow vectors)."""
    for k in range(2):
        field[..., k] = cv2.medianBlur(np.ascontiguousarray(field[..., k]), 5)
    return field


def projective_flow(coef: np.ndarray, x: np.ndarray, y: np.ndarray, size: tuple[int, int]
                     ) -> np.ndarray:
    """Evaluate the eight-parameter projective flow (planar scene, camera rotation) at x, y.

    ``u = a1 + a2 x + a3 y + a7 x^2 + a8 x y``, ``v = a4 + a5 x + a6 y + a7 x y + a8 y^2``
    with ``x, y`` centred on the image of ``size`` (h, w) and scaled by its larger side.
    It is linear in ``coef``: evaluated with unit vectors it gives the model's columns.

    Returns
    -------
    ndarray of shape ``x.shape + (2,)``
    """
    h, w = size
    scale = np.float32(1.0 / max(h, w))
    x = (x - np.float32(0.5 * w)) * scale
    y = (y - np.float32(0.5 * h)) * scale
    a1, a2, a3, a4, a5, a6, a7, a8 = np.asarray(coef, dtype=np.float32)
    quad = a7 * x + a8 * y
    return np.stack([a1 + a2 * x + a3 * y + quad * x, a4 + a5 * x + a6 * y + quad * y],
                    axis=-1)


#: The projective fit of a field takes every this-many-th sample of its grid, each way.
PROJECTIVE_STRIDE = 8


def fit_projective(values: np.ndarray, ok: np.ndarray, x: np.ndarray, y: np.ndarray,
                    stride: int = PROJECTIVE_STRIDE) -> np.ndarray | None:
    """Robust fit of the projective flow (:func:`projective_flow`) to ``values`` at ``(x, y)``.

    Iteratively reweighted least squares (four rounds, residuals beyond 1.5 times their
    median down-weighted: independently moving objects and parallax are outliers) over
    every ``stride``-th reliable sample of the grid.

    Parameters
    ----------
    values : ndarray of shape (h, w, 2)
        Vectors to fit (a flow, a velocity).
    ok : ndarray of bool, shape (h, w)
        Samples that may be used.
    x, y : ndarray of shape (h, w)
        Where each vector belongs.
    stride : int
        Sampling step of the grid.

    Returns
    -------
    ndarray of shape (8,) or None
        The coefficients; None with fewer than 32 usable samples.
    """
    h, w = values.shape[:2]
    sub = (slice(None, None, stride), slice(None, None, stride))
    use = ok[sub].ravel()
    n = int(use.sum())
    if n < 32:
        return None
    scale = 1.0 / max(h, w)
    xs = (x[sub].ravel()[use].astype(np.float64) - 0.5 * w) * scale
    ys = (y[sub].ravel()[use].astype(np.float64) - 0.5 * h) * scale
    target = values[sub].reshape(-1, 2)[use].astype(np.float64)
    return _projective_irls(xs, ys, np.concatenate([target[:, 0], target[:, 1]]), 4)


def _moment_table() -> np.ndarray:
    """Map the 15 monomials of degree <= 4 in (x, y) onto the projective flow's normal matrix.

    The model's column ``j`` is, for ``u`` and for ``v``, a monomial (or nothing):
    ``u: 1, x, y, -, -, -, x^2, x y``; ``v: -, -, -, 1, x, y, x y, y^2``. Entry ``(j, k)``
    of the normal matrix is the weighted sum of the products of those, so it is a sum of
    weighted moments: row ``8 j + k`` of the table counts which.
    """
    powers = [(i - k, k) for i in range(5) for k in range(i + 1)]  # 1, x, y, x^2, ...
    u = [(0, 0), (1, 0), (0, 1), None, None, None, (2, 0), (1, 1)]
    v = [None, None, None, (0, 0), (1, 0), (0, 1), (1, 1), (0, 2)]
    table = np.zeros((64, len(powers)))
    for j in range(8):
        for k in range(8):
            for col in (u, v):
                a, b = col[j], col[k]
                if a is not None and b is not None:
                    table[8 * j + k, powers.index((a[0] + b[0], a[1] + b[1]))] += 1
    return table


#: The projective flow's normal matrix from the weighted moments (:func:`_moment_table`).
_MOMENTS = _moment_table()


def _projective_irls(xs: np.ndarray, ys: np.ndarray, target: np.ndarray, rounds: int
                     ) -> np.ndarray:
    """Robust least squares of the projective flow: ``rounds`` solves of its normal equations.

    ``target`` holds every sample's ``u``, then every sample's ``v``; each sample is
    weighted ``1 / max(r / (1.5 median(r) + 1e-3), 1)`` by the length ``r`` of its
    residual in the last solve. The normal matrix is formed from the samples' weighted
    moments (:data:`_MOMENTS`: one product of the weights with 15 columns, where the
    model's own rows are 16 columns of twice as many); 2040 samples, four rounds: about
    0.4 ms a call, where the same steps with the model's rows took 0.8 ms.
    """
    n = xs.size
    xx, xy, yy = xs * xs, xs * ys, ys * ys
    powers = np.stack([np.ones(n), xs, ys, xx, xy, yy, xx * xs, xx * ys, xs * yy, yy * ys,
                       xx * xx, xx * xy, xx * yy, xy * yy, yy * yy])  # (15, n)
    au = np.stack([powers[0], xs, ys, xx, xy])  # u's columns 0, 1, 2, 6, 7
    av = np.stack([powers[0], xs, ys, xy, yy])  # v's columns 3, 4, 5, 6, 7
    tu, tv = target[:n], target[n:]
    q = np.ones(n)  # the squared weights
    coef = np.zeros(8)
    for _ in range(rounds):
        normal = (_MOMENTS @ (powers @ q)).reshape(8, 8)
        normal.flat[::9] += 1e-12
        bu, bv = au @ (q * tu), av @ (q * tv)
        rhs = np.array([bu[0], bu[1], bu[2], bv[0], bv[1], bv[2], bu[3] + bv[3],
                        bu[4] + bv[4]])
        coef = np.linalg.solve(normal, rhs)
        du = coef[[0, 1, 2, 6, 7]] @ au - tu
        dv = coef[[3, 4, 5, 6, 7]] @ av - tv
        r = np.sqrt(du * du + dv * dv)
        weight = 1.0 / np.maximum(r / (1.5 * float(median_along(r)) + 1e-3), 1.0)
        q = weight * weight
    return coef


def advected_velocity(vel: np.ndarray, ok: np.ndarray, flow: np.ndarray,
                       ahead: np.ndarray, stride: int = PROJECTIVE_STRIDE) -> np.ndarray:
    """Each pixel's velocity, moved along its path ahead through the smooth flow field.

    ``vel`` is each pixel's mean velocity over its measured path to the neighbour frame
    (``flow``), so it belongs half-way along that path, at ``s + flow(s) / 2``; the
    pixel moves on by ``ahead`` to the reference time and meets the velocity half-way
    there, at ``s + ahead / 2`` (midpoint rule). The flow of a camera rotating or moving
    over a plane at a steady rate is a fixed field over the image, the projective flow
    (:func:`projective_flow`): fitted (robustly, to the reliable pixels) and used for
    the change of velocity between the two places. What is left (the depth of each
    point) travels with the point. A constant velocity per pixel misses the acceleration
    a point sees moving through a zoom or a perspective; the residual of its fit would
    carry objects' edges through the frame.

    The projective field beat an affine one, a quadratic one and the full per-pixel
    field on the research pairs (``docs/tuning.md``).
    """
    h, w = vel.shape[:2]
    gx, gy = pixel_grid(h, w)
    mid_x, mid_y = gx + 0.5 * flow[..., 0], gy + 0.5 * flow[..., 1]
    coef = fit_projective(vel, ok, mid_x, mid_y, stride)
    if coef is None:
        return vel
    return (vel + projective_flow(coef, gx + 0.5 * ahead[..., 0], gy + 0.5 * ahead[..., 1],
                                   (h, w))
            - projective_flow(coef, mid_x, mid_y, (h, w)))


#: Side (px) of the patch over which :func:`snap_to_global` compares a pixel's flow with
#: the global motion.
SNAP_WINDOW = 9


def snap_to_global(cur: np.ndarray, other: np.ndarray, flow: np.ndarray, ok: np.ndarray,
                   window: int = SNAP_WINDOW) -> np.ndarray:
    """Give pixels the frame's global motion where it explains them as well as their own flow.

    Dense flow is smoothed across motion boundaries (the background next to a moving
    object or a nearer layer moves partly with it) and is noisy where the scene has little
    structure. The frame's global motion -- the projective flow (:func:`projective_flow`)
    fitted robustly to the reliable pixels: camera rotation, a plane, the dominant layer --
    replaces a pixel's own flow where it matches the other frame at least as well over a
    ``window`` x ``window`` patch (sum of absolute differences). Pixels of independently
    moving objects and of other layers keep their flow: the global motion does not match
    them (measurements: ``docs/tuning.md``).

    Parameters
    ----------
    cur, other : ndarray of shape (h, w), float32
        The frame and the neighbour the flow points to.
    flow : ndarray of shape (h, w, 2), float32
        Flow from ``cur`` to ``other`` (``cur(s) ~ other(s + flow(s))``).
    ok : ndarray of bool, shape (h, w)
        Pixels whose flow is reliable (the fit's samples).
    window : int
        Side of the patch compared (px).

    Returns
    -------
    ndarray of shape (h, w, 2), float32
    """
    h, w = flow.shape[:2]
    gx, gy = pixel_grid(h, w)
    coef = fit_projective(flow, ok, gx, gy)
    if coef is None:
        return flow
    glob, at_glob, at_flow = projective_maps(coef, flow)  # the model and both fields' maps
    # The flow where the global motion costs more (the costs are finite: a patch mean).
    worse = costlier(cur, other, at_glob, at_flow, window)
    cv2.copyTo(np.ascontiguousarray(flow, np.float32), worse, glob)
    return glob


#: Under the vibration model a pixel keeps its motion beyond the camera trajectory's where its
#: flow matches its patch better by over this (grey levels; ``docs/tuning.md#camera_margin``).
CAMERA_MARGIN = 1.0


def snap_to_camera(cur: np.ndarray, other: np.ndarray, flow: np.ndarray, resid: np.ndarray,
                   window: int = SNAP_WINDOW, margin: float = CAMERA_MARGIN) -> np.ndarray:
    """Drop a pixel's motion beyond the camera's where the camera's matches it as well.

    A vibration bends the rows, which no projective flow follows
    (:func:`snap_to_global` keeps the flow there); the camera trajectory with its
    sinusoids does. Where the trajectory's own flow (``flow - resid``) matches the other
    frame within ``margin`` of the pixel's flow over a ``window`` x ``window`` patch, the
    pixel's residual is the flow's noise: it becomes 0. Objects and near layers that
    move otherwise keep theirs (measurements: ``docs/tuning.md#camera_margin``).

    Parameters
    ----------
    cur, other : ndarray of shape (h, w), float32
        The frame and the neighbour the flow points to.
    flow : ndarray of shape (h, w, 2), float32
        Flow from ``cur`` to ``other``.
    resid : ndarray of shape (h, w, 2), float32
        Its part beyond the camera trajectory's.
    window : int
        Side of the patch compared (px).
    margin : float
        Mean difference (0-255) by which the flow must match better.

    Returns
    -------
    ndarray of shape (h, w, 2), float32

    Examples
    --------
    A still frame and a flow of noise: the camera's (none) matches as well.

    >>> img = np.random.default_rng(0).uniform(0, 255, (20, 20)).astype(np.float32)
    >>> noise = np.full((20, 20, 2), 0.05, np.float32)
    >>> float(np.abs(snap_to_camera(img, img, noise, noise)).max())
    0.0
    """
    h, w = flow.shape[:2]
    gx, gy = pixel_grid(h, w)
    cam = flow - resid
    keep = costlier(cur, other, (gx + cam[..., 0], gy + cam[..., 1]),
                    (gx + flow[..., 0], gy + flow[..., 1]), window, margin)
    out = np.zeros_like(resid)
    cv2.copyTo(np.ascontiguousarray(resid, np.float32), keep, out)
    return out


def at_reference(sides: list[tuple[np.ndarray, np.ndarray, np.ndarray]],
                 ahead: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each pixel's residual motion carried to the reference time, from its neighbours'.

    With both neighbours' residuals reliable, the quadratic through ``(e_a, r_a)``, the
    pixel's own time ``(0, 0)`` and ``(e_b, r_b)`` (Lagrange), evaluated at ``ahead``; with
    one, the straight line through it and ``(0, 0)``.

    Parameters
    ----------
    sides : list of (e, r, ok)
        Per neighbour: the time from each pixel's own to where its flow lands in that
        frame, shape (h, w); the residual flow there, (h, w, 2); its reliable pixels.
    ahead : ndarray of shape (h, 1) or (h, w)
        The time from each pixel's own to the reference.

    Returns
    -------
    field : ndarray of shape (h, w, 2), float32
        Zero where no side is reliable.
    fallback : ndarray of bool, shape (h, w)
        Where no side is reliable.

    Examples
    --------
    >>> e = np.full((1, 2), 1.0, np.float32); r = np.ones((1, 2, 2), np.float32)
    >>> ok = np.array([[True, False]])
    >>> field, fallback = at_reference([(e, r, ok)], np.full((1, 1), 0.5, np.float32))
    >>> field[..., 0].tolist(), fallback.tolist()
    ([[0.5, 0.0]], [[False, True]])
    """
    h, w = sides[0][2].shape
    if len(sides) == 2 and ahead.shape == (h, 1):  # one time a row: the compiled kernel
        (ea, ra, oka), (eb, rb, okb) = ((np.ascontiguousarray(e, np.float32),
                                         np.ascontiguousarray(r, np.float32),
                                         np.ascontiguousarray(ok)) for e, r, ok in sides)
        return quadratic_ahead(ea, ra, oka, eb, rb, okb,
                               np.ascontiguousarray(ahead, np.float32))
    field = np.zeros((h, w, 2), np.float32)
    fallback = np.ones((h, w), dtype=bool)
    if len(sides) == 2:
        (ea, ra, oka), (eb, rb, okb) = sides
        both = oka & okb
        gap = ea - eb
        la = ahead - eb
        la *= ahead
        la /= ea * gap
        lb = ahead - ea
        lb *= ahead
        lb /= eb * -gap
        quad = both_axes(la) * ra
        quad += both_axes(lb) * rb
        put(field, quad, both)
        fallback &= ~both
    for e, r, ok in sides:  # one side only: the straight line through it
        only = ok & fallback
        if only.any():
            put(field, both_axes(ahead / e) * r, only)
            fallback &= ~only
    return field, fallback
