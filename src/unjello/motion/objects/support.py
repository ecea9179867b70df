"""Where a fitted object is: its region, its shape, and the pixels its motion explains.

The regions of failed flow around the seeds (:func:`spin_regions`), each one's
:func:`elongation` (a rotation sweeps a disc), the pixels a fitted rotation or drift
explains better than the motion around them (:func:`spin_support`: a propeller's region
also shows the background between its blades), and whether they show edges the fit
could see (:func:`edged`). :func:`~unjello.motion.objects.spinners.keep_spinning` uses
them.
"""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np

from .folds import fill_hull
from .rigid import MOVING, Spin, Track, costs, predict

__all__ = ["spin_regions", "elongation", "spin_support", "edged", "SOFT_EDGE", "HOLE",
           "LARGEST", "EDGE", "EDGED", "SUPPORT_WINDOW", "HIDDEN_COST", "HIDDEN_REACH"]


#: A hole in the pixels a rotation explains is filled (taken as part of the object) up to
#: this share of their area.
HOLE = 0.02


#: The width (px, a Gaussian's sigma) over which an object's weight falls to its surroundings'
#: motion at its edge. (``docs/tuning.md#soft_edge``)
SOFT_EDGE = 0.6


#: A rotation, or a drift against the motion around it, is used only where EDGED of its pixels
#: have a 3x3 Sobel gradient of EDGE or more (``docs/tuning.md#edge``).
EDGE, EDGED = 20.0, 0.02


#: Seen from one side, a pixel the motion around puts on the object's place in the neighbour
#: stays with the object only where its drift explains it outright (``docs/tuning.md#hidden_cost``).
HIDDEN_COST = 15.0


#: ... or where it is flat and no edge lies within the two motions' difference across the
#: frame (pixels, at most this): a flat band carried with the object looks the same.
HIDDEN_REACH = 15


#: Side (px) of the square over which a fitted object's pixels must differ from their
#: surroundings to be the object's.
SUPPORT_WINDOW = 3


def spin_support(image: np.ndarray, others: Sequence[tuple[np.ndarray, float]],
                 region: np.ndarray, spin: Spin, track: Track, t_ref: float,
                 readout: float, window: int = SUPPORT_WINDOW) -> np.ndarray:
    """Weight (0-1) of the rotation at each pixel of ``region``; 0 elsewhere.

    A pixel takes the rotation where it matches the neighbours better than the motion of
    the surroundings over a ``window`` square (the blades, not the background seen
    between them), and so do the gaps and small holes inside what does; the weight is smoothed
    over a pixel so that the seam does not tear.
    """
    h, w = image.shape
    ys, xs = np.nonzero(region)
    pts = np.stack([xs, ys], axis=1).astype(np.float64)
    both = costs(image, others, pts, np.repeat(spin.centre[None], 2, 0),
                  np.array([spin.omega, 0.0]), track, t_ref, readout / h,
                  drift=np.stack([spin.drift, np.zeros(2)]))
    rot = np.zeros((h, w), np.float32)
    still = np.zeros((h, w), np.float32)
    rot[ys, xs], still[ys, xs] = both
    if len(others) >= 2 and not spin.omega:
        # What is behind a passing object may be covered on one side: where it shows
        # edges, the surroundings' motion scored by the side that sees it best. (Not
        # for a rotation: a spinner's arm matches another arm on one side.)
        sides = [costs(image, [o], pts, spin.centre[None], np.zeros(1), track, t_ref,
                       readout / h)[0] for o in others]
        grad, near = _gradient(image, region)
        edged = grad[region[near]] >= EDGE  # (the region's pixels in the order of ys, xs)
        still[ys, xs] = np.where(edged, np.minimum.reduce(sides), both[1])
    box = (window, window)
    rot_box = cv2.boxFilter(rot, -1, box)
    better = (rot_box < cv2.boxFilter(still, -1, box)) & region
    if len(others) == 1 and not spin.omega:
        better = _not_behind(better, rot_box, image, pts, others[0][1], spin, track, t_ref,
                             readout)
    # One piece: gaps and small holes inside the object (a flat patch matches either
    # way) take the rotation too, so that the object is not torn between the two motions;
    # large holes (the background seen between a wheel's spokes) do not.
    k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (7, 7))
    solid = cv2.morphologyEx(better.astype(np.uint8), cv2.MORPH_CLOSE, k)
    count, holes, stats, _ = cv2.connectedComponentsWithStats(1 - solid, connectivity=4)
    small = HOLE * int(solid.sum())
    for i in range(1, count):
        x, y, bw, bh, area = stats[i]
        inside = x > 0 and y > 0 and x + bw < w and y + bh < h  # not the outside
        if inside and area <= small:
            solid[holes == i] = 1
    better = solid.astype(bool) & region
    weight = cv2.GaussianBlur(better.astype(np.float32), (0, 0), SOFT_EDGE)
    return np.where(region, weight, 0.0).astype(np.float32)


def _not_behind(better: np.ndarray, cost: np.ndarray, image: np.ndarray, pts: np.ndarray,
                offset: float, spin: Spin, track: Track, t_ref: float, readout: float
                ) -> np.ndarray:
    """Leave out of ``better`` the background that the lone neighbour shows the object over.

    Seen from one side, background beside a drifting object that the object covers in
    the neighbour (the band a near pole has just uncovered) matches the motion around it
    nowhere -- it lands on the object -- and the drift wins it by default: carried with
    the object, it draws whatever it holds over the background beside (a helmet's rim
    cut where the pole passed). Where the object lies in the neighbour is ``better``
    carried by the drift (a pixel wider); a pixel that the motion around it puts there
    stays only where the drift explains it outright (``cost`` under :data:`HIDDEN_COST`,
    on an edge: the object's own outline), or where it is flat and no edge but the
    object's lies within the two motions' difference across the frame
    (:data:`HIDDEN_REACH` at most): a flat band carried with the object looks the same,
    and fills the background it uncovered.
    """
    h, w = better.shape
    row_time = readout / h
    q = np.rint(predict(pts, row_time * pts[:, 1], np.repeat(spin.centre[None], 2, 0),
                        np.zeros(2), track, t_ref, offset, row_time,
                        drift=np.stack([spin.drift, np.zeros(2)]))).astype(np.intp)
    xs, ys = pts[:, 0].astype(np.intp), pts[:, 1].astype(np.intp)
    inside = (q[..., 0] >= 0) & (q[..., 0] < w) & (q[..., 1] >= 0) & (q[..., 1] < h)
    place = np.zeros((h, w), np.uint8)
    mine = better[ys, xs] & inside[0]
    place[q[0, mine, 1], q[0, mine, 0]] = 1
    there = cv2.dilate(place, np.ones((3, 3), np.uint8)) > 0
    hidden = inside[1].copy()
    hidden[hidden] = there[q[1, hidden, 1], q[1, hidden, 0]]
    if not hidden.any():
        return better
    behind = np.zeros((h, w), bool)
    behind[ys[hidden], xs[hidden]] = True
    reach = int(min(HIDDEN_REACH, np.ceil(np.hypot(*spin.drift)
                                          * np.abs(row_time * ys - t_ref).max())))
    square = np.ones((2 * reach + 1, 2 * reach + 1), np.uint8)
    grad, box = _gradient(image, cv2.dilate((better | behind).astype(np.uint8), square) > 0)
    edge = np.zeros((h, w), bool)
    edge[box] = grad >= EDGE
    own = cv2.dilate((better & ~behind).astype(np.uint8), np.ones((3, 3), np.uint8))
    busy = cv2.dilate((edge & (own == 0)).astype(np.uint8), square) > 0
    keep = ((cost < HIDDEN_COST) & edge) | (better & ~busy)
    return np.where(behind, keep, better)


#: Regions of failed flow over this share of the frame are no objects (content entering,
#: a whole moving scene).
LARGEST = 0.25


def spin_regions(seeds: np.ndarray, image: np.ndarray,
                 others: Sequence[tuple[np.ndarray, float]], track: Track, t_ref: float,
                 readout: float, *, largest: float = LARGEST) -> np.ndarray:
    """Whole objects around ``seeds`` (where the flow failed), as labels (0: none).

    Flow fails on a spinning object in patches. The object is what the motion of the
    surroundings does not explain -- pixels that differ from where that motion puts them
    in the neighbours by :data:`MOVING` grey levels or more -- joined across small gaps;
    each such piece that a seed touches stands for one object as its convex hull. Pieces
    over ``largest`` of the frame (content entering it, a whole moving scene) are not
    objects.
    """
    h, w = image.shape
    ys, xs = np.mgrid[0:h, 0:w]
    pts = np.stack([xs.ravel(), ys.ravel()], axis=1).astype(np.float64)
    still = costs(image, others, pts, np.zeros((1, 2)), np.zeros(1), track, t_ref,
                   readout / h, iterations=3)[0].reshape(h, w).astype(np.float32)
    moving = cv2.GaussianBlur(still, (0, 0), 2.0) >= MOVING
    size = max(5, w // 40) | 1
    k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))
    joined = cv2.morphologyEx(moving.astype(np.uint8), cv2.MORPH_CLOSE, k)
    count, labels, stats, _ = cv2.connectedComponentsWithStats(joined)
    out = np.zeros((h, w), np.int32)
    n = 0
    for i in range(1, count):
        piece = labels == i
        if stats[i, cv2.CC_STAT_AREA] > largest * h * w or not seeds[piece].any():
            continue
        n += 1
        fill_hull(out, piece, n)
    return out


def elongation(region: np.ndarray) -> float:
    """Return how many times longer than wide a region is (the spread of its pixels).

    The square root of the ratio of the principal variances of its pixels' positions: 1
    for a disc or a square, about 1.9 for a half disc, the length over the width for a
    bar.

    Examples
    --------
    >>> bar = np.zeros((60, 60), bool); bar[:, 25:31] = True
    >>> round(elongation(bar))
    10
    """
    ys, xs = np.nonzero(region)
    if xs.size < 3:
        return 1.0
    var = np.linalg.eigvalsh(np.cov(np.stack([xs, ys]).astype(np.float64)))
    return float(np.sqrt(var[1] / max(var[0], 1e-9)))


def _gradient(image: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, tuple[slice, slice]]:
    """Return the 3x3 Sobel gradient's magnitude on ``mask``'s box (non-empty), and the box.

    Computed on the box and a pixel around it (the Sobel's reach): as on the whole frame.
    """
    ys, xs = np.nonzero(mask)
    y0, x0 = max(0, ys.min() - 1), max(0, xs.min() - 1)
    part = np.ascontiguousarray(image[y0:ys.max() + 2, x0:xs.max() + 2], np.float32)
    grad = np.hypot(cv2.Sobel(part, cv2.CV_32F, 1, 0, ksize=3),
                    cv2.Sobel(part, cv2.CV_32F, 0, 1, ksize=3))
    return grad, np.s_[y0:y0 + part.shape[0], x0:x0 + part.shape[1]]


def edged(image: np.ndarray, support: np.ndarray) -> bool:
    """Whether ``support`` shows edges of its own: :data:`EDGED` of it at :data:`EDGE` or more.

    A band of flat sky beside a near pole is unexplained by the motion around it (a
    neighbour shows the pole there) and a drift that carries it past the pole in both
    neighbours matches it, backwards or not; an object's own pixels have its outline.
    """
    if not support.any():
        return False
    grad, box = _gradient(image, support)
    return bool(np.mean(grad[support[box]] >= EDGE) >= EDGED)
