"""A dense flow's inverse: where the other frame's pixels came from.

:func:`~unjello.motion.flow.dis.flow_pair` measures one flow (DIS) and inverts it for the other
way, a fraction of the cost of a second flow. In a fast pan each frame's side shows what
entered it, matched to nothing; inverting there needs the row's own motion
(:func:`row_modes`).
"""

from __future__ import annotations

import cv2
import numpy as np

from ..._kernels.field import grid_plus
from ...timing import pixel_grid

__all__ = ["invert_flow", "row_modes"]


#: Width (px) of the histogram bins a row's dominant motion is read from.
MODE_BIN = 2.0


#: Rows around each row whose flows enter its histogram.
MODE_BAND = 9


def row_modes(values: np.ndarray, bin_px: float = MODE_BIN, band: int = MODE_BAND) -> np.ndarray:
    """Each row's most common ``(dx, dy)`` in a flow (or samples of its columns).

    Per component, a histogram of ``bin_px`` bins over ``band`` rows around each row;
    the mean of the row's values within a bin of its peak. Over 135 rows, every few
    rows' (the same for the rows between). The median of a row's middle
    half was the dominant flow before: in a pan of 60 % of the width a frame, the middle
    half of the other frame is mostly content that entered it, whose flow is a guess, and
    that median was the guess's (+25 px where the scene moved -192).

    Returns
    -------
    ndarray of shape (h, 2), float32

    Examples
    --------
    >>> flow = np.zeros((4, 10, 2), np.float32)
    >>> flow[..., 0] = [-192.0] * 4 + [3.0, -40.0, 25.0, 7.0, -11.0, 60.0]
    >>> row_modes(flow)[:, 0].tolist()
    [-192.0, -192.0, -192.0, -192.0]
    """
    h = values.shape[0]
    step = max(1, h // 135)  # every 4th row of 540: the histograms span 9 rows anyway
    values = values[::step]
    band = max(3, band // step | 1)
    rows = np.repeat(np.arange(values.shape[0]), values.shape[1])
    out = np.empty((values.shape[0], 2), np.float32)
    for k in range(2):
        v = values[..., k]
        lo = float(np.floor(v.min()))
        idx = ((v - lo) / bin_px).astype(np.int64)
        bins = int(idx.max()) + 1
        counts = np.bincount(rows * bins + idx.ravel(), minlength=v.shape[0] * bins)
        hist = cv2.blur(counts.reshape(-1, bins).astype(np.float32), (3, band),
                        borderType=cv2.BORDER_REPLICATE)
        peak = np.argmax(hist, axis=1)
        near = np.abs(idx - peak[:, None]) <= 1
        count = near.sum(axis=1)
        out[:, k] = np.where(count > 0, (v * near).sum(axis=1) / np.maximum(count, 1),
                             lo + (peak + 0.5) * bin_px)
    return np.repeat(out, step, axis=0)[:h]


#: Fixed-point iterations of a flow's inverse.
INVERT_ITERATIONS = 3


def invert_flow(flow: np.ndarray, iterations: int = INVERT_ITERATIONS,
                images: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Invert a dense flow by the fixed point ``G(q) = -F(q + G(q))``.

    If ``F`` carries the pixels of ``b`` to ``a`` (``b(s) ~ a(s + F(s))``), ``G`` carries
    those of ``a`` back to ``b``. The flow is sampled bilinearly at the current estimate;
    the iteration converges wherever the flow does not fold. Where content of ``a`` has no
    counterpart in ``b`` (disocclusion) the result is the flow of the surroundings.

    It starts from ``-F(q)``. Where the camera moves fast that is a guess at ``a``'s
    sides: ``b`` shows there what entered the frame, matched to nothing, while ``a``'s
    content sits a pan's width further in ``b``; the iteration may then settle on the
    guess and leave the frame. Near the sides (as far in as the motion, and 8 px), where
    it leaves the frame, it starts again from the row's dominant flow (:func:`row_modes`),
    which is kept where it lands inside and returns (within :data:`_INVERSE_MISS` px).
    Where both land inside (two fixed points: the flow alone cannot tell which is right),
    the restart wins where the first lands on what entered ``b`` (content the row's
    dominant flow carries outside ``a``), else the one that carries ``a``'s grey levels
    onto like ones in ``b``, given the ``images``.

    Parameters
    ----------
    flow : ndarray of shape (h, w, 2), float32
    iterations : int
    images : tuple of ndarray, optional
        ``(a, b)``, grey, to choose between two fixed points by.

    Returns
    -------
    ndarray of shape (h, w, 2), float32

    Examples
    --------
    >>> f = np.zeros((20, 30, 2), np.float32); f[..., 0] = 2.5
    >>> bool(np.allclose(invert_flow(f)[..., 0], -2.5))
    True
    >>> pan = np.zeros((20, 60, 2), np.float32); pan[..., 0] = -20.0
    >>> pan[:, :20, 0] = 7.0  # entering at b's left: a guess
    >>> inv = invert_flow(pan)  # a's content at q is b's at q + 20
    >>> bool(np.allclose(inv[:, :7, 0], 20.0))
    True
    """
    h, w = flow.shape[:2]
    gx, gy = pixel_grid(h, w)

    back = -flow  # sampled: -F(q + G) (bilinear weights are symmetric under negation)

    def iterate(inv: np.ndarray, top: int, left: int) -> np.ndarray:
        maps = (np.empty(inv.shape[:2], np.float32), np.empty(inv.shape[:2], np.float32))
        for _ in range(iterations):
            mx, my, _ = grid_plus(inv, top, left, maps)
            inv = cv2.remap(back, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        return inv

    inv = iterate(back, 0, 0)
    quarter = max(1, w // 4)
    dominant = -row_modes(flow[:, ::max(1, w // 160)])
    # What entered the other frame is as wide as the motion: the sides that far (and 8 px).
    side = int(min(quarter, 8 + np.abs(dominant[:, 0]).max()))
    for cols in (slice(0, side), slice(w - side, w)):
        xs, ys = np.ascontiguousarray(gx[:, cols]), np.ascontiguousarray(gy[:, cols])
        _, out = _inverse_miss(flow, inv[:, cols], xs, ys)
        # In doubt: what leaves the frame; with the images, what strays from the row's
        # dominant motion too (a second fixed point, or a near object's own).
        doubt = out | ((np.abs(inv[:, cols] - dominant[:, None]).max(axis=-1) > 2.0)
                       if images is not None else False)
        rows = np.flatnonzero(doubt.any(axis=1))
        if not rows.size:
            continue
        r = slice(rows[0], rows[-1] + 1)
        start = np.broadcast_to(dominant[r, None, :], (r.stop - r.start, xs.shape[1], 2))
        again = iterate(np.ascontiguousarray(start, np.float32), r.start, cols.start or 0)
        miss2, out2 = _inverse_miss(flow, again, xs[r], ys[r])
        fits = ~out2 & (miss2 <= _INVERSE_MISS)
        better = out[r] & fits
        part = inv[r, cols]
        # A first fixed point on what entered b (the row's motion carries it outside a)
        # matches nothing in a: the restart, where it returns, is the pixel's.
        lx = xs[r] + part[..., 0] - dominant[r, None, 0]
        ly = ys[r] + part[..., 1] - dominant[r, None, 1]
        better |= doubt[r] & fits & _leaves(lx, ly, h, w)
        if images is not None:
            unlike = [_unlike(images, g, xs[r], ys[r], r, cols) for g in (part, again)]
            better |= doubt[r] & fits & ~out[r] & (unlike[1] + 2.0 < unlike[0])
        part[better] = again[better]
    return inv


def _unlike(images: tuple[np.ndarray, np.ndarray], inv: np.ndarray, xs: np.ndarray,
            ys: np.ndarray, rows: slice, cols: slice) -> np.ndarray:
    """Blurred ``|a(q) - b(q + G(q))|`` over a block of ``a`` (grey levels)."""
    a, b = images
    seen = cv2.remap(np.asarray(b, np.float32), np.ascontiguousarray(xs + inv[..., 0]),
                     np.ascontiguousarray(ys + inv[..., 1]), cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_REPLICATE)
    return cv2.GaussianBlur(cv2.absdiff(np.asarray(a[rows, cols], np.float32), seen),
                            (0, 0), 2.0)


#: A second start of an inverse flow near the frame's sides is kept only where it returns
#: within this many pixels (``|G + F(q + G)|``, :func:`invert_flow`).
_INVERSE_MISS = 1.0


def _inverse_miss(flow: np.ndarray, inv: np.ndarray, xs: np.ndarray, ys: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """``|G + F(q + G)|`` at the points ``(xs, ys)`` of the inverse ``G``; where it leaves."""
    h, w = flow.shape[:2]
    lx = np.ascontiguousarray(xs + inv[..., 0])
    ly = np.ascontiguousarray(ys + inv[..., 1])
    back = cv2.remap(flow, lx, ly, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    return np.hypot(inv[..., 0] + back[..., 0], inv[..., 1] + back[..., 1]), _leaves(lx, ly, h, w)


def _leaves(x: np.ndarray, y: np.ndarray, h: int, w: int) -> np.ndarray:
    """Return where the points ``(x, y)`` lie outside an ``h`` x ``w`` frame's pixels."""
    return (x < -0.5) | (x > w - 0.5) | (y < -0.5) | (y > h - 0.5)
