"""Compiled scoring of drifts: where an object moving on its own appears, and how well.

:func:`unjello.motion.objects.rigid.fit_drift` scores thousands of velocities a frame for a near
pole the flow lost: for each, every point of the object is followed to the scanline that
images it in each neighbouring frame (the paper's eq. 10 timing, a fixed point), and its
grey level compared with what that frame shows there. In NumPy each step of that fixed
point is a call on an (m, n) array of times: the camera path's interpolation, a complex
product, a stack; a 320 x 180 clip with two poles spent most of its correction there
(0.37 CPU s a frame against 0.07 without them). Here it is one loop per drift and point.

The path is evaluated as :class:`~unjello.motion.objects.rigid.PathTrack` does (linear between
its samples, held beyond them, rounded to float32, then its velocity, scale and drift);
the neighbours are sampled bilinearly with the position clamped to the frame (OpenCV's
``INTER_LINEAR`` with ``BORDER_REPLICATE``, without its 1/32-pixel quantisation). Its
reference, :func:`unjello.motion.objects.rigid.costs` on NumPy, agrees within 0.05 grey levels a
point (``tests/motion/objects/test_rigid.py``).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numba import njit

from .jit import compiled

__all__ = ["drift_costs"]


def drift_costs(own: np.ndarray, others: list[tuple[np.ndarray, float]], pts: np.ndarray,
                times: np.ndarray, path: np.ndarray, u: complex, scale: tuple[float, float],
                drift0: complex, row_time: float, iterations: int, truncate: float
                ) -> Callable[[np.ndarray], np.ndarray]:
    """Return a scorer of drifts: each point's truncated difference with where a drift puts it.

    Everything but the drifts is made ready once: a pattern search scores a few drifts
    at a time, hundreds of times, on the same points.

    Parameters
    ----------
    own : ndarray of shape (n,)
        The points' grey levels in their own frame.
    others : list of (image, offset)
        One or two neighbouring frames (float32, the frame's size) and their start times
        relative to the frame's, in frame intervals.
    pts : ndarray of shape (n, 2)
        The points (x, y) in the frame.
    times, path : ndarray of shape (T,)
        The track's samples: times, and positions as ``x + iy``.
    u, drift0 : complex
        The track's own velocity before and after its scale.
    scale : tuple of float
    row_time : float
        Time between consecutive rows (frame intervals).
    iterations : int
        Steps of the fixed point for the scanline (the last only moves the point).
    truncate : float
        Grey-level difference at which a point's cost saturates; also the cost of a point
        no neighbour shows.

    Returns
    -------
    callable
        Takes drifts, shape (m, 2) (px per frame interval, on top of the track's), and
        returns the costs, shape (m, n), float64: averaged over the neighbours in which
        the point lands inside the frame.
    """
    if not 1 <= len(others) <= 2:
        raise ValueError("one or two neighbours")
    (a, off_a), (b, off_b) = others[0], others[-1]
    fixed = (np.ascontiguousarray(own, np.float64), np.ascontiguousarray(a, np.float32),
             float(off_a), np.ascontiguousarray(b, np.float32), float(off_b), len(others),
             np.ascontiguousarray(pts, np.float64))
    track = (np.ascontiguousarray(times, np.float64),
             np.ascontiguousarray(np.real(path), np.float64),
             np.ascontiguousarray(np.imag(path), np.float64),
             np.array([u.real, u.imag, scale[0], scale[1], drift0.real, drift0.imag]),
             float(row_time), int(iterations), float(truncate))

    # Points sorted by row: the scanline a point is imaged on does not depend on its
    # column, so the points of one row share it.
    rows = np.argsort(fixed[6][:, 1], kind="stable")

    def score(drifts: np.ndarray) -> np.ndarray:
        drifts = np.ascontiguousarray(drifts, np.float64)
        out = np.empty((len(drifts), len(fixed[6])))
        # Without rotation a point's scanline depends on the drift's vertical part alone:
        # solved once per distinct one (``vys``; ``slot``: each drift's).
        vys, slot = np.unique(drifts[:, 1], return_inverse=True)
        _drift_costs(*fixed, rows, drifts, vys, slot.ravel(), *track, out,
                     np.empty((len(vys), 2, 3)))
        return out

    return score


@njit
def _track(times: np.ndarray, px: np.ndarray, py: np.ndarray, t: float, k: np.ndarray
           ) -> tuple[float, float]:
    """Return the track at time ``t``; ``k`` = (u.x, u.y, scale.x, scale.y, drift.x, drift.y)."""
    last = times.size - 1
    if t <= times[0]:
        x, y = px[0], py[0]
    elif t >= times[last]:
        x, y = px[last], py[last]
    else:
        lo, hi = 0, last
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if times[mid] <= t:
                lo = mid
            else:
                hi = mid
        a = (t - times[lo]) / (times[lo + 1] - times[lo])
        x = px[lo] + a * (px[lo + 1] - px[lo])
        y = py[lo] + a * (py[lo + 1] - py[lo])
    x = float(np.float32(x)) + t * k[0]  # the path rounded to float32, as the camera's is
    y = float(np.float32(y)) + t * k[1]
    return x * k[2] + t * k[4], y * k[3] + t * k[5]


@njit(inline="always")
def _sample(img: np.ndarray, x: float, y: float) -> float:
    """``img`` at ``(x, y)``, bilinear, the position clamped to the frame."""
    h, w = img.shape
    x = min(max(x, 0.0), w - 1.0)
    y = min(max(y, 0.0), h - 1.0)
    x0, y0 = int(x), int(y)
    x1, y1 = min(x0 + 1, w - 1), min(y0 + 1, h - 1)
    ax, ay = x - x0, y - y0
    return ((img[y0, x0] * (1.0 - ax) + img[y0, x1] * ax) * (1.0 - ay)
            + (img[y1, x0] * (1.0 - ax) + img[y1, x1] * ax) * ay)


@compiled
def _drift_costs(own: np.ndarray, a: np.ndarray, off_a: float, b: np.ndarray, off_b: float,
                 count: int, pts: np.ndarray, rows: np.ndarray, drifts: np.ndarray,
                 vys: np.ndarray, slot: np.ndarray, times: np.ndarray, px: np.ndarray,
                 py: np.ndarray, k: np.ndarray, row_time: float, iterations: int,
                 truncate: float, out: np.ndarray, work: np.ndarray) -> None:
    h, w = a.shape
    # Per distinct vertical drift and neighbour (``work``): the time from the point's own to
    # where it is imaged there, and the track's move till then -- the same for every point
    # of a row (``rows`` visits them row by row).
    for r in range(rows.size):
        i = rows[r]
        x, y = pts[i, 0], pts[i, 1]
        if r == 0 or y != pts[rows[r - 1], 1]:
            t_s = row_time * y
            sx, sy = _track(times, px, py, t_s, k)
            for v in range(vys.size):
                for o in range(count):
                    off = off_a if o == 0 else off_b
                    t = off + row_time * y
                    for _ in range(iterations - 1):
                        t = off + row_time * (y + _track(times, px, py, t, k)[1] - sy
                                              + vys[v] * (t - t_s))
                    cx, cy = _track(times, px, py, t, k)
                    work[v, o, 0] = t - t_s
                    work[v, o, 1] = cx - sx
                    work[v, o, 2] = cy - sy
        for d in range(drifts.shape[0]):
            vx, vy, v = drifts[d, 0], drifts[d, 1], slot[d]
            total, seen = 0.0, 0
            for o in range(count):
                qx = x + work[v, o, 1] + vx * work[v, o, 0]
                qy = y + work[v, o, 2] + vy * work[v, o, 0]
                if 0.0 <= qx <= w - 1 and 0.0 <= qy <= h - 1:
                    img = a if o == 0 else b
                    total += min(math.fabs(_sample(img, qx, qy) - own[i]), truncate)
                    seen += 1
            out[d, i] = total / seen if seen else truncate
