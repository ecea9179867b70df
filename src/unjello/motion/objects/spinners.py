"""Do no harm, step two: keep a spinning object whole by fitting it a rigid rotation.

A propeller, a wheel or a fidget spinner turns so fast that optical flow between frames
fails on it (its blades move tens of pixels and look alike: the flow aliases), and the
per-pixel map folds there (:mod:`unjello.motion.objects.folds`). But a rolling shutter images
such an object one scanline at a time while it turns, and the distortion that results --
blades bent into arcs, thinned on one side and fattened on the other -- is that of a
rigid rotation sampled per scanline, exactly as the camera's motion is (the paper's
eq. 10 timing): a point at ``s``, imaged at ``t_s = t_k + rho s_y / h``, was at

``p = C(t_ref) + R(omega (t_ref - t_s)) (s - C(t_s))``

at the reference time, where ``C(t)`` is the rotation's centre, carried by the motion
around it, and ``omega`` the angular velocity (radians per frame interval).

:func:`fit_spin` finds ``omega`` and the centre from the frame and its neighbours: each
candidate predicts where every pixel of the region appears in a neighbouring frame
(solved per pixel for the scanline that images it), and the candidate whose predictions
match the neighbours best (a truncated absolute difference) wins. Between frames the
object turns by ``omega`` times the interval, which a symmetric object (three blades)
cannot tell from ``omega`` plus a multiple of its symmetry; within the frame it turns by
``omega`` times the readout across its height, which tells them apart -- so the search
covers many turns per frame, as real propellers make. :func:`spin_field` is the
correction of the fitted rotation, :func:`spin_source` its inverse (where each output
pixel's content was: the layer the warper shows in front of the rest),
:func:`spin_support` the pixels it explains better than the motion around them (a
propeller's region also shows the background between its blades).
"""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np

from .folds import fill_hull
from .rigid import (
    MOVING,
    Spin,
    Track,
    at,
    carried,
    carried_out,
    costs,
    fit_drift,
    pattern_search,
    predict,
    prepare,
    rotate,
)

__all__ = ["Spin", "fit_spin", "spin_field", "spin_source", "spin_support", "spin_regions",
           "keep_spinning", "elongation", "MAX_SPIN", "WHOLE", "MAX_ELONGATION"]

#: The search covers rotations up to this many radians per frame interval either way
#: (two turns: 60 rev/s at 30 fps).
MAX_SPIN = 4 * np.pi
#: A hole in the pixels a rotation explains is filled (taken as part of the object) up to
#: this share of their area.
HOLE = 0.02
#: An object whose rotation explains at least this share of it (its hull) takes the
#: rotation whole: what it leaves out is its rim and seams, where a cut shows.
WHOLE = 0.85
#: The width (px, a Gaussian's sigma) over which an object's weight falls to its
#: surroundings' motion at its edge. Measured (``python benchmarks/edges.py --seeds 4``,
#: near poles): 1.0 px mixed the object's and its surroundings' pictures over a band
#: about five pixels wide; 0.6 px +0.17 dB, 0.4 px +0.16, 0.8 px +0.08; the simulated
#: propeller and wheel 0.149x -> 0.135x and 0.132x -> 0.117x.
SOFT_EDGE = 0.6
#: At most this many objects a frame are fitted a motion of their own (the largest).
MAX_OBJECTS = 6
#: A rotation in the picture's plane sweeps a disc: an object longer than this many times
#: its width (the spread of its pixels along its axes) is fitted no rotation. The swept
#: discs of the simulated and real spinners measure 1.0-1.5 (a half disc cut by the
#: frame's edge 1.9); poles the flow lost 4.5-8.3, where rotations of a turn a frame were
#: fitted and one was used (``docs/measurements.md``).
MAX_ELONGATION = 3.0
#: Pixels around the failed flow (the seeds) that a drift is fitted on again where none
#: explains an object's whole hull (:func:`keep_spinning`).
TIGHT = 4
#: A rotation, or a drift against the motion around it (:data:`ALONG`), is used only where
#: :data:`EDGED` of the pixels it explains have a gradient (3x3 Sobel, grey levels) of
#: :data:`EDGE` or more: the simulated poles' and objects' supports 11-39 %, flat sky
#: beside a pole none (``docs/tuning.md``).
EDGE, EDGED = 20.0, 0.02
#: An object is carried by a drift of its own where that explains it this many times
#: better than the motion around it (:func:`keep_spinning`'s ``drift_gain``), below a
#: rotation's ``min_gain``: a flat pole's drift is seen at its edges alone, and the rocket
#: 10 %/0.4 pair's near pole, fitted its true drift, scored 2.92-3.08 by the flow's detail
#: (``docs/measurements.md``).
DRIFT_GAIN = 2.5

#: A region more than this share of which, carried by the camera's motion, lands outside
#: both neighbours is fitted nothing (:func:`keep_spinning`): no frame can check a motion
#: there. A diagonal pan brings such a corner in at one side and out at the other; a
#: drift "explained" it by landing on whatever looked alike (the astronaut's diagonal
#: 15 %/1.0 clip: two frames, 0.089x -> 0.032x and 0.070x -> 0.044x, once not fitted;
#: ``docs/measurements.md``). With one neighbour all content entering is so, and a near
#: pole entering is fitted its drift there: the test is for two.
UNCHECKED = 0.25
#: With a neighbour on each side, one that the camera's motion carries more than this
#: share of an object outside sees it too little to check a motion: the object is fitted
#: as seen from the other alone (along the motion around it, :data:`ALONG`). A near pole
#: by the side it leaves through was fitted drifts across the pan, which the lone
#: neighbour's aperture leaves free (``python benchmarks/edges.py --seeds 4``: astronaut
#: clips 25 %/0.4 34.50 -> 35.32 dB, 15 %/1.0 worst frame 22.67 -> 29.94; 0.3 and 0.7 as
#: much).
ONE_SIDE = 0.5
#: Seen from one side only, a drift is taken only where it points the way the motion
#: around the object does (the cosine of their angle at least this): a nearer object in
#: a pan (parallax). One side alone lets a flat region match a drift backwards.
ALONG = 0.7
#: Seen from one side only, a pixel the motion around a drifting object puts where the
#: object lies in the neighbour (background it covered there) stays with the object only
#: where the drift explains it outright: a mean truncated difference under this (grey
#: levels) on an edge (:func:`_not_behind`).
HIDDEN_COST = 15.0
#: ... or where it is flat and no edge lies within the two motions' difference across the
#: frame (pixels, at most this): a flat band carried with the object looks the same.
HIDDEN_REACH = 15


def fit_spin(image: np.ndarray, others: Sequence[tuple[np.ndarray, float]],
             region: np.ndarray, track: Track, t_ref: float, readout: float, *,
             max_spin: float = MAX_SPIN, coarse_radius: float = 16.0,
             hints: Sequence[tuple[np.ndarray, float]] = (), search: bool = True
             ) -> Spin | None:
    """Fit a rotation per scanline to ``region`` of ``image``.

    Every rotation up to ``max_spin`` about every centre near the region's centroid is
    scored on a copy shrunk until the region's radius is about ``coarse_radius`` px
    (where a grid of a few hundred rotations and 25 centres is affordable and blur widens
    each candidate's basin); the best few are refined at full size by a shrinking
    pattern search over centre and rotation.

    Parameters
    ----------
    image : ndarray of shape (h, w), float32
        The frame (grey).
    others : sequence of (ndarray, float)
        Neighbouring frames and their start times relative to this frame's start.
    region : ndarray of bool, shape (h, w)
        The object's pixels (a blob where the per-pixel motion failed).
    track : callable
        ``C``'s motion: the displacement of the region's surroundings at times relative
        to the frame's start, ``(n,) -> (n, 2)``.
    t_ref : float
        The frame's reference time relative to its start.
    readout : float
        Readout time in frame intervals.
    max_spin : float
        Largest rotation searched, radians per frame interval.
    coarse_radius : float
        The region's radius (px) in the shrunk copy.
    hints : sequence of (ndarray, float)
        Rotations (centre at ``t_ref``, ``omega``) to refine besides the search's best:
        the previous frame's, carried along (a spinning object keeps spinning).
    search : bool
        False: refine the ``hints`` only, without the coarse search.

    Returns
    -------
    Spin or None
        None when the region is too small to fit (a radius under 8 px) or there is no
        neighbour.
    """
    prep = prepare(image, others, region, track, t_ref, readout, coarse_radius)
    if prep is None:
        return None
    h = image.shape[0]
    centroid, radius, scale, fine = prep.centroid, prep.radius, prep.scale, prep.fine
    s_radius = radius * scale[0]
    grid = np.arange(-max_spin, max_spin + 1e-9, 1.5 / s_radius)
    grid = grid[np.abs(grid) * s_radius >= 1.0]  # a turn the rim shows
    found = []
    for dy in (-2, 0, 2) if search else ():
        for dx in (-2, 0, 2):
            c = centroid * scale + (dx, dy)
            scores = costs(prep.small, prep.sothers, prep.spts, np.repeat(c[None], len(grid), 0),
                            grid, prep.strack, t_ref, readout / prep.small.shape[0],
                            iterations=3).mean(axis=1)
            for i in np.argsort(scores)[:2]:
                found.append((float(scores[i]), c / scale, float(grid[i])))
    found.sort(key=lambda x: x[0])

    # Fine: a pattern search from the best few, the centre kept near the region's.
    def cost(x: np.ndarray) -> np.ndarray:
        """Score rotations ``x`` (m, 3: centre and omega) together."""
        return costs(image, others, fine, x[:, :2], x[:, 2], track, t_ref,
                     readout / h).mean(axis=1)

    d_omega = 1.0 / radius  # a turn that moves the rim by 1 px in a frame interval
    steps = np.array([(1.0, 0, 0), (-1.0, 0, 0), (0, 1.0, 0), (0, -1.0, 0), (0, 0, d_omega),
                      (0, 0, -d_omega)])
    results = []
    starts = [(c, om) for _, c, om in found[:2]] + [
        (np.asarray(c, np.float64), om) for c, om in hints
        if np.linalg.norm(np.asarray(c) - centroid) <= radius / 3]
    if not starts:
        return None
    for centre, omega in starts:
        x = np.array([centre[0], centre[1], omega], np.float64)
        results.append(pattern_search(
            cost, x, float(cost(x[None])[0]), steps, (2.0, 1.0, 0.5, 0.25),
            allowed=lambda p: np.hypot(*(p[:, :2] - centroid).T) <= radius / 3))
    best, x = min(results, key=lambda r: r[0])
    centre, omega = x[:2], float(x[2])
    return Spin(centre=centre, omega=omega, cost=best,
                still_cost=float(cost(np.array([[centre[0], centre[1], 0.0]]))[0]))


def spin_field(spin: Spin, shape: tuple[int, int], track: Track, t_ref: float,
               readout: float) -> np.ndarray:
    """Return the correction ``D(s) = s - p`` of a rotation at every pixel of the frame.

    ``p = C(t_ref) + R(omega (t_ref - t_s)) (s - C(t_s))`` with ``C(t) = centre +
    track(t) - track(t_ref)``: the camera's part is ``track(t_s) - track(t_ref)``, the
    paper's eq. 26, and the rotation's part turns each scanline back by what the object
    turned since the reference time. An object moving on its own is carried by ``track``
    plus its :attr:`Spin.drift`.
    """
    h, w = shape
    track = carried(track, spin.drift)
    row_time = readout / h
    t_rows = row_time * np.arange(h)
    c_ref = track(np.array([t_ref]))[0]
    moved = track(t_rows) - c_ref  # (h, 2)
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float64)
    s = np.stack([xs, ys], axis=-1)
    rel = s - (spin.centre + moved[:, None, :])
    p = spin.centre + rotate(rel, spin.omega * (t_ref - t_rows)[:, None])
    return (s - p).astype(np.float32)


def spin_source(spin: Spin, shape: tuple[int, int], track: Track, t_ref: float,
                readout: float, iterations: int = 8) -> np.ndarray:
    """Return the rotation's backward displacement ``s - p`` at every output pixel ``p``.

    The inverse of :func:`spin_field`: ``s = C(t_s) + R(-omega (t_ref - t_s)) (p -
    C(t_ref))``, whose time ``t_s`` is that of the scanline ``s`` lies on -- solved by
    iterating on that scanline alone (it converges while the rim moves less than a row
    per row of readout, as :func:`fit_spin`'s predictions do).
    """
    h, w = shape
    track = carried(track, spin.drift)
    row_time = readout / h
    c_ref = np.asarray(track(np.array([t_ref])), np.float64)[0]
    if not spin.omega:  # a drift: the source row depends on the output row alone
        ys1 = np.arange(h, dtype=np.float64)[:, None]
        rel_y = ys1 - spin.centre[1]
        y = ys1.copy()
        for _ in range(iterations):
            moved = spin.centre + at(track, row_time * y) - c_ref  # (h, 1, 2)
            y = np.clip(moved[..., 1] + rel_y, 0, h - 1)
        xs1 = np.arange(w, dtype=np.float64)[None, :]
        src_x = moved[..., 0] + (xs1 - spin.centre[0])
        src_y = np.broadcast_to(moved[..., 1] + rel_y, (h, w))
        return np.stack([src_x - xs1, src_y - ys1], axis=-1).astype(np.float32)
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float64)
    rel = np.stack([xs, ys], axis=-1) - spin.centre
    y = ys.copy()
    for _ in range(iterations):
        t = row_time * y
        src = spin.centre + at(track, t) - c_ref + rotate(rel, -spin.omega * (t_ref - t))
        y = np.clip(src[..., 1], 0, h - 1)
    return (src - np.stack([xs, ys], axis=-1)).astype(np.float32)


def spin_support(image: np.ndarray, others: Sequence[tuple[np.ndarray, float]],
                 region: np.ndarray, spin: Spin, track: Track, t_ref: float,
                 readout: float, window: int = 3) -> np.ndarray:
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


def spin_regions(seeds: np.ndarray, image: np.ndarray,
                 others: Sequence[tuple[np.ndarray, float]], track: Track, t_ref: float,
                 readout: float, *, largest: float = 0.25) -> np.ndarray:
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


def _edged(image: np.ndarray, support: np.ndarray) -> bool:
    """Whether ``support`` shows edges of its own: :data:`EDGED` of it at :data:`EDGE` or more.

    A band of flat sky beside a near pole is unexplained by the motion around it (a
    neighbour shows the pole there) and a drift that carries it past the pole in both
    neighbours matches it, backwards or not; an object's own pixels have its outline.
    """
    if not support.any():
        return False
    grad, box = _gradient(image, support)
    return bool(np.mean(grad[support[box]] >= EDGE) >= EDGED)


def _along(drift: np.ndarray, behind: np.ndarray) -> bool:
    """Whether ``drift`` points the way ``behind`` does, within :data:`ALONG` (parallax)."""
    norm = float(np.hypot(*drift) * np.hypot(*behind))
    return norm > 0 and float(np.dot(drift, behind)) >= ALONG * norm


def keep_spinning(field: np.ndarray, image: np.ndarray,
                  others: Sequence[tuple[np.ndarray, float]], seeds: np.ndarray,
                  track: Track, t_ref: float, readout: float, *,
                  hints: Sequence[tuple[np.ndarray, float]] = (), min_gain: float = 3.0,
                  steady_gain: float = 1.6, drift_gain: float = DRIFT_GAIN,
                  min_area: int = 400, rotations: bool = True
                  ) -> tuple[np.ndarray, list[Spin], np.ndarray, list[Spin],
                             tuple[np.ndarray, ...]]:
    """Give each failed object that a drift or a rotation explains that motion's correction.

    Each object around the ``seeds`` (:func:`spin_regions`, at least ``min_area`` px, the
    :data:`MAX_OBJECTS` largest) is first fitted a velocity of its own (:func:`fit_drift`;
    where none explains its hull ``steady_gain`` times better than the motion around
    it, again on its pixels within :data:`TIGHT` of the seeds; one under ``min_gain``,
    again on the pixels it explains; seen from one side only, along the motion around
    it): one that it explains ``drift_gain`` times better than
    the motion around it, and moves a pixel or more a frame, is an object moving on its own
    (a near pole the flow could not follow) and takes that drift as a rotation would
    (below). Without ``rotations`` that is all; otherwise the others are fitted a
    rotation (:func:`fit_spin`, from the ``hints`` first, then by a full search; then
    again on the pixels its rotation explains, leaving out the background seen through
    the object). It is used when it matches the
    neighbours at least ``min_gain`` times better than the motion around it -- or
    ``steady_gain`` times when the previous frame found the same rotation (``hints``:
    within 15 % and a quarter of the radius) -- and turns its rim by a pixel or more per
    frame. Its correction (:func:`spin_field`) then replaces ``field`` with the weight of
    :func:`spin_support` -- or over its whole hull, where the rotation explains
    :data:`WHOLE` of it (a spinner: what it leaves out is its rim and seams, where a cut
    shows); elsewhere ``field`` (the surroundings' motion, from
    :func:`unjello.motion.objects.folds.keep_whole`) stays. And since a turned-back arm lands on
    what the frame shows as background, which a forward field cannot show it over, the
    rotation's source (:func:`spin_source`) and the weight come back as a layer in front of
    the field. A rotation, or a drift against the motion around it, whose pixels show no
    edges of their own (:func:`_edged`: flat sky a neighbour shows a near pole over) is
    not used. With a neighbour on each side, a region mostly carried outside both by the
    camera's motion (:data:`UNCHECKED`) is fitted nothing, and one carried outside one of
    them (:data:`ONE_SIDE`) is fitted as seen from the other alone.

    Returns
    -------
    field : ndarray of shape (h, w, 2)
    spins : list of Spin
        The rotations and drifts (``omega`` 0) used.
    weight : ndarray of shape (h, w), float32
        The rotations' weight at each pixel (0 where none was used).
    candidates : list of Spin
        Every rotation fitted, used or not: the next frame's ``hints`` (no drifts).
    fronts : tuple of ndarray
        Per rotation used, its layer in front of ``field`` (:attr:`FrameMotion.front
        <unjello.trajectory.FrameMotion>`): :func:`spin_source` and the weight.
    """
    labels = spin_regions(seeds, image, others, track, t_ref, readout)
    beyond = ([carried_out(seeds.shape, offset, track, readout) for _, offset in others]
              if len(others) >= 2 else None)
    unchecked = np.logical_and.reduce(beyond) if beyond is not None else None
    behind = (at(track, np.array([t_ref + 0.5])) - at(track, np.array([t_ref - 0.5])))[0]
    out, spins, candidates, fronts = field, [], [], []
    used = np.zeros(seeds.shape, np.float32)
    areas = np.bincount(labels.ravel())[1:]
    for i in 1 + np.argsort(-areas)[:MAX_OBJECTS]:  # the largest, to bound the cost
        region = labels == i
        if region.sum() < min_area or (
                unchecked is not None
                and (region & unchecked).sum() > UNCHECKED * region.sum()):
            continue
        radius = float(np.sqrt(region.sum() / np.pi))
        # With a neighbour on each side, one that sees too little of the object (the
        # camera's motion carries it out there) checks nothing: seen from the other alone.
        seen = others if beyond is None else [
            o for o, out in zip(others, beyond, strict=True)
            if (region & out).sum() <= ONE_SIDE * region.sum()] or others
        # Seen from one side, only a drift along the motion around it is taken (_along):
        # it is searched there (across it a flat pole's motion is unsure, and a drift
        # across it that matched a little better turned a pole's fit down).
        side = behind if len(seen) < 2 and np.any(behind) else None

        def good(spin: Spin, radius: float = radius, sides: int = len(seen)) -> bool:
            steady = any(abs(spin.omega - om) <= 0.15 * abs(om)
                         and np.linalg.norm(spin.centre - c) <= radius / 4 for c, om in hints)
            if sides < 2:  # one side tells aliases apart poorly: both are needed
                return spin.gain >= min_gain and steady
            return spin.gain >= min_gain or (spin.gain >= steady_gain and steady)

        # An object moving on its own (a near pole) is no spinner: a drift that explains
        # it is taken before any rotation is searched; seen from one side, only along the
        # motion around it (:data:`ALONG`).
        spin = fit_drift(image, seen, region, track, t_ref, readout, along=side)
        if spin is None or spin.gain < steady_gain:
            # A hull that joined other unexplained pieces (a suit's edges beside a pole)
            # is mostly what the surroundings' motion explains, and no drift (or a weak
            # one) fits it: again on its pixels near the failed flow.
            size = 2 * TIGHT + 1
            tight = region & cv2.dilate(seeds.astype(np.uint8), np.ones((size, size),
                                                                         np.uint8)).astype(bool)
            if min_area / 2 <= tight.sum() < region.sum() / 2:
                spin = fit_drift(image, seen, tight, track, t_ref, readout,
                                 along=side) or spin
        if spin is not None and spin.gain < min_gain:
            # Again on what it explains: a near pole's hull holds what it covers (seen
            # from one side, a pole at 50 % of the width a frame explained 1.53 times).
            support = spin_support(image, seen, region, spin, track, t_ref, readout) > 0.5
            if support.sum() >= min_area / 2:
                spin = fit_drift(image, seen, support, track, t_ref, readout,
                                 along=side) or spin
        drifting = spin is not None and spin.gain >= drift_gain and bool(
            np.hypot(*spin.drift) >= 1.0) and (len(seen) >= 2 or _along(spin.drift, behind))
        if not drifting and elongation(region) > MAX_ELONGATION:
            continue  # a long thin object (a pole, a rail) is no swept disc: no rotation
        if not drifting and not rotations:
            continue
        for search in (False, True) if not drifting else ():
            # From last frame's rotation, else a full search.
            if not search and not hints:
                continue
            spin = fit_spin(image, seen, region, track, t_ref, readout, hints=hints,
                            search=search)
            if spin is None:
                continue
            # The hull holds background too (between a propeller's blades): fitted again
            # on what the first rotation explains, the object alone.
            support = spin_support(image, seen, region, spin, track, t_ref, readout) > 0.5
            if support.sum() >= min_area / 2:
                spin = fit_spin(image, seen, support, track, t_ref, readout,
                                hints=[(spin.centre, spin.omega)], search=False) or spin
            if good(spin):
                break
        if spin is None:
            continue
        if not drifting:
            candidates.append(spin)
            if not good(spin) or abs(spin.omega) * radius < 1.0:
                continue
        weight = spin_support(image, seen, region, spin, track, t_ref, readout)
        if (spin.omega or not _along(spin.drift, behind)) and not _edged(image, weight > 0.5):
            continue  # a flat patch: a motion "explains" it by missing what covers it
        if (weight > 0.5).sum() >= WHOLE * region.sum():
            weight = cv2.GaussianBlur(region.astype(np.float32), (0, 0), SOFT_EDGE)
        weight = weight[..., None]
        out = out * (1 - weight) + spin_field(spin, seeds.shape, track, t_ref,
                                              readout) * weight
        used = np.maximum(used, weight[..., 0])
        spins.append(spin)
        fronts.append(np.dstack([spin_source(spin, seeds.shape, track, t_ref, readout),
                                 weight]).astype(np.float32))
    return out.astype(field.dtype), spins, used, candidates, tuple(fronts)
