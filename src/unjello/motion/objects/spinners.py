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
:func:`~unjello.motion.objects.support.spin_support` the pixels it explains better than
the motion around them (a propeller's region also shows the background between its
blades).
"""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np

from .rigid import (
    COARSE_RADIUS,
    Spin,
    Track,
    at,
    carried,
    carried_out,
    costs,
    fit_drift,
    pattern_search,
    prepare,
    rotate,
)
from .support import (
    SOFT_EDGE,
    edged,
    elongation,
    spin_regions,
    spin_support,
)

__all__ = ["Spin", "fit_spin", "spin_field", "spin_source", "keep_spinning", "MAX_SPIN", "WHOLE",
           "MAX_ELONGATION"]

#: The search covers rotations up to this many radians per frame interval either way
#: (two turns: 60 rev/s at 30 fps).
MAX_SPIN = 4 * np.pi
#: An object whose rotation explains at least this share of it (its hull) takes the
#: rotation whole: what it leaves out is its rim and seams, where a cut shows.
WHOLE = 0.85
#: At most this many objects a frame are fitted a motion of their own (the largest).
MAX_OBJECTS = 6
#: A rotation sweeps a disc: an object longer than this many times its width is fitted no
#: rotation (``docs/tuning.md#max_elongation``).
MAX_ELONGATION = 3.0
#: Pixels around the failed flow (the seeds) that a drift is fitted on again where none
#: explains an object's whole hull (:func:`keep_spinning`).
TIGHT = 4
#: An object drifts on its own where that explains it this many times better than the motion
#: around it (:func:`keep_spinning`; ``docs/tuning.md#drift_gain``).
DRIFT_GAIN = 2.5

#: A region over this share of which the camera's motion carries outside both neighbours is
#: fitted nothing: no frame checks it (:func:`keep_spinning`; ``docs/tuning.md#unchecked``).
UNCHECKED = 0.25
#: A neighbour that sees over this share of an object carried outside cannot check it: the
#: object is fitted from the other side alone (:data:`ALONG`; ``docs/tuning.md#one_side``).
ONE_SIDE = 0.5
#: Seen from one side, a drift is taken only where it points the way the motion around does
#: (cosine at least this: a nearer object in a pan; ``docs/tuning.md#along``).
ALONG = 0.7


def fit_spin(image: np.ndarray, others: Sequence[tuple[np.ndarray, float]],
             region: np.ndarray, track: Track, t_ref: float, readout: float, *,
             max_spin: float = MAX_SPIN, coarse_radius: float = COARSE_RADIUS,
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


#: Fixed-point iterations that find where a rotation, imaged row by row, took a pixel from.
SOURCE_ITERATIONS = 8


def spin_source(spin: Spin, shape: tuple[int, int], track: Track, t_ref: float,
                readout: float, iterations: int = SOURCE_ITERATIONS) -> np.ndarray:
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


def _along(drift: np.ndarray, behind: np.ndarray) -> bool:
    """Whether ``drift`` points the way ``behind`` does, within :data:`ALONG` (parallax)."""
    norm = float(np.hypot(*drift) * np.hypot(*behind))
    return norm > 0 and float(np.dot(drift, behind)) >= ALONG * norm


#: A fitted rotation or drift is used where it explains the object this many times better
#: than the motion around it ...
MIN_GAIN = 3.0


#: ... or this many times, where the previous frame found the same rotation.
STEADY_GAIN = 1.6


#: Objects of failed flow smaller than this (px) are not fitted.
MIN_AREA = 400


def keep_spinning(field: np.ndarray, image: np.ndarray,
                  others: Sequence[tuple[np.ndarray, float]], seeds: np.ndarray,
                  track: Track, t_ref: float, readout: float, *,
                  hints: Sequence[tuple[np.ndarray, float]] = (), min_gain: float = MIN_GAIN,
                  steady_gain: float = STEADY_GAIN, drift_gain: float = DRIFT_GAIN,
                  min_area: int = MIN_AREA, rotations: bool = True
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
    edges of their own (:func:`~unjello.motion.objects.support.edged`: flat sky a
    neighbour shows a near pole over) is not used. With a neighbour on each side, a region
    mostly carried outside both by the camera's motion (:data:`UNCHECKED`) is fitted
    nothing, and one carried outside one of them (:data:`ONE_SIDE`) is fitted as seen from
    the other alone.

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
        if (spin.omega or not _along(spin.drift, behind)) and not edged(image, weight > 0.5):
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
