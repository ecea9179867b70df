"""The optical-flow toolkit shared by the dense method, the gyro calibration and the readout.

DIS optical flow (OpenCV) between two grey frames, its forward-backward consistency
check, its inversion, where it lands and the dominant flow of each row (the patches'
costs and the sharpening at motion boundaries: :mod:`unjello.motion.flow.patches`). Sign: a
flow ``F`` from ``a`` to ``b`` has ``a(s) ~ b(s + F(s))`` (see :mod:`unjello.timing`).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Literal

import cv2
import numpy as np

from ..._kernels.field import grid_plus
from ..._kernels.pixelwise import consistency, shorth_sorted
from ...errors import SettingsError
from ...timing import pixel_grid
from .inverse import invert_flow
from .patches import patch_cost, refine_motion_edges, unmatched_entering
from .phase import phase_correlate

__all__ = ["PRESETS", "LARGE_MOTION", "ROW_AGREE", "FlowSettings", "global_shifts",
           "optical_flow", "landing", "consistent", "row_flows", "half_row_flows", "flow_pair",
           "explains", "misses", "median_along", "textured", "STILL_BETTER", "STILL_SHARE",
           "STILL_REGION", "TEXTURE"]

PRESETS = {"ultrafast": cv2.DISOPTICAL_FLOW_PRESET_ULTRAFAST,
            "fast": cv2.DISOPTICAL_FLOW_PRESET_FAST,
            "medium": cv2.DISOPTICAL_FLOW_PRESET_MEDIUM}


#: Up to this width the medium preset estimates flow at full resolution, so small frames
#: get flow as fine as large ones (``docs/tuning.md``).
_FULL_RES_WIDTH = 480

#: A row's flow weighs the share of its pixels within this many pixels of it
#: (:func:`row_flows`' ``agree``; the dense method's row equations).
ROW_AGREE = 1.5
#: Motion of this share of the width a frame is large: over about two pixels of DIS's
#: coarsest level (``docs/tuning.md#large_motion``).
LARGE_MOTION = 0.05
#: Copies' width for the global translation, and the phase response below which its DIS run
#: must also lower the mean patch cost to be used (``docs/tuning.md#_shift_width``).
_SHIFT_WIDTH, _SHIFT_RESPONSE = 128, 0.1
#: Side (px) of the patches whose photometric cost picks between the two runs.
_PICK_PATCH = 15

#: Zero motion replaces the flow at a pixel of two-dimensional texture (:func:`textured`) whose
#: patch it matches at most this share of the flow's cost (``docs/tuning.md#still_better``) ...
STILL_BETTER = 0.5
#: ... where it does at least this share of the textured pixels within this square (px).
STILL_SHARE, STILL_REGION = 0.5, 31
#: ... and pixels without texture among them, where zero motion matches their patch within
#: this mean difference (0-255) or the pair's median patch cost under its flow.
STILL_MATCH = 1.0
#: Two-dimensional texture: a structure tensor's smaller eigenvalue of at least this share of
#: its 90th percentile in the frame (:func:`textured`).
TEXTURE = 0.05

#: A cheaper flow explains a pair (:func:`explains`) unless over this share of its pixels land
#: on grey levels unlike their own (``docs/tuning.md#photo_miss``).
PHOTO_MISS = 0.05

#: ... a pixel misses where its grey level is off by more than this or four times the
#: pair's median difference (0-255, blurred by a Gaussian of 2 px).
_PHOTO_LEVEL = 12.0


def global_shifts(a: np.ndarray, b: np.ndarray, width: int = _SHIFT_WIDTH
                  ) -> list[tuple[np.ndarray, float]]:
    """Measure the frame's dominant translation ``t`` (``a(s) ~ b(s + t)``).

    By phase correlation (:func:`~unjello.motion.flow.phase.phase_correlate`: up to the
    frame's size, where the cyclic reading is :data:`LARGE_MOTION` or more) on copies
    ``width`` px wide.

    Returns
    -------
    list of (ndarray of shape (2,), float)
        ``(dx, dy)`` in pixels of ``a``, and the correlation peak's strength (0-1: low
        for no dominant translation): the cyclic correlation's, then, where the copies
        overlap far better at another, that one (the last is the best).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> b = cv2.GaussianBlur(rng.uniform(0, 255, (240, 320)).astype(np.float32), (0, 0), 3)
    >>> a = np.roll(b, (-5, -40), axis=(0, 1))  # a(s) = b(s + (40, 5))
    >>> [(np.round(shift).tolist(), response > 0.3) for shift, response in global_shifts(a, b)]
    [([40.0, 5.0], True)]
    """
    h, w = a.shape[:2]
    k = min(1.0, width / w)
    size = (max(8, round(w * k)), max(8, round(h * k)))
    sa = cv2.resize(np.asarray(a, np.float32), size, interpolation=cv2.INTER_AREA)
    sb = cv2.resize(np.asarray(b, np.float32), size, interpolation=cv2.INTER_AREA)
    scale = np.array([w / size[0], h / size[1]], np.float32)
    return [(shift * scale, response)
            for shift, response in phase_correlate(sa, sb, LARGE_MOTION * size[0])]


def textured(image: np.ndarray, share: float = TEXTURE) -> np.ndarray:
    """Pixels of two-dimensional texture: corners and texture, not edges or flat areas.

    Where the smaller eigenvalue of the local structure tensor (5 x 5 px,
    :func:`cv2.cornerMinEigenVal`) is at least ``share`` of its 90th percentile in the
    frame. Bool mask of ``image``'s shape.
    """
    e = cv2.cornerMinEigenVal(np.ascontiguousarray(image, np.float32), 5)
    return e >= share * float(np.percentile(e, 90))


def _still_where_it_matches(a: np.ndarray, b: np.ndarray, flow: np.ndarray) -> np.ndarray:
    """Zero motion where it matches ``b`` clearly better than ``flow``, over a region.

    At pixels of two-dimensional texture whose patch zero motion matches at most
    :data:`STILL_BETTER` of the flow's cost, where they are at least :data:`STILL_SHARE`
    of the textured pixels within :data:`STILL_REGION`: a still background beside a
    large object that crosses it, whose flow DIS's coarse levels took from the object
    (a launch tower's lattice matched one period off, consistent both ways). Where those
    kept still are most of the textured pixels around, pixels without texture keep still
    too where zero motion matches them no worse than their flow and than the pair's
    median patch cost (or :data:`STILL_MATCH`): the flat sky between the tower's bars,
    not content entering a pan's frame, which no motion matches. Scattered pixels that
    zero motion happens to match (a dim texture in a fading pan) stay.
    """
    h, w = a.shape
    gx, gy = pixel_grid(h, w)
    af, bf = a.astype(np.float32), b.astype(np.float32)
    box = (_PICK_PATCH, _PICK_PATCH)
    zero = cv2.boxFilter(cv2.absdiff(af, bf), -1, box)  # zero motion's patch cost
    cost = patch_cost(af, bf, gx, gy, flow, _PICK_PATCH)
    better = zero < STILL_BETTER * cost
    if not better.any():  # a pan: nowhere (the texture measure costs as much again)
        return flow
    tex = textured(af)
    better &= tex
    region = (STILL_REGION, STILL_REGION)
    textures = np.maximum(cv2.blur(tex.astype(np.float32), region), 1e-6)

    def most(mask: np.ndarray) -> np.ndarray:  # where ``mask`` holds most textured pixels
        return cv2.blur(mask.astype(np.float32), region) / textures >= STILL_SHARE

    still = better & most(better)
    # Flat pixels among them, where zero motion matches as well as the flow and as the
    # pair's flow typically does (a flow that missed matches no motion: entering content).
    if still.any():
        match = max(float(np.median(cost)), STILL_MATCH)
        still |= most(still) & ~tex & (zero <= np.minimum(cost, match))
    return np.where(still[..., None], np.float32(0), flow)


def _pick_by_cost(a: np.ndarray, b: np.ndarray, flow: np.ndarray, other: np.ndarray,
                  whole: Literal["mean", "median"] | None = None) -> np.ndarray:
    """Per pixel, ``other`` where its patch matches ``b`` better than ``flow``'s.

    With ``whole``, ``other`` is used only if it matches better over the frame too (a
    lower mean, or median, patch cost); else ``flow`` is returned as it is. The median
    is the scene's: content that enters or leaves the frame matches under no flow, and
    its costs rule the mean; an alias that matches it somewhere (one lattice taken for
    another) then wins over the frame's true motion.
    """
    h, w = a.shape
    gx, gy = pixel_grid(h, w)
    af = a.astype(np.float32)
    bf = b.astype(np.float32)
    cost = patch_cost(af, bf, gx, gy, flow, _PICK_PATCH)
    cost_other = patch_cost(af, bf, gx, gy, other, _PICK_PATCH)
    if whole is not None:
        reduce = np.mean if whole == "mean" else np.median
        if float(reduce(cost_other)) >= float(reduce(cost)):
            return flow
    return np.where((cost_other < cost)[..., None], other, flow)


_engines = threading.local()


def _engine(preset: str, finest_scale: int | None, refinement: int | None,
            started: bool = False) -> cv2.DISOpticalFlow:
    """Return this thread's DIS instance for these settings, made once.

    A DIS instance keeps its pyramids and patch buffers from call to call; made anew
    for every frame pair, each flow allocated them again, and on a pool of threads the
    allocator handed the memory back and faulted it in again every frame
    (``docs/history/measurements.md``). One instance keeps no state between pairs as long as it
    is always, or never, given a starting flow (``started``): once given one, OpenCV's
    DIS uses it again on later calls without one, so the two kinds of call get their own.
    """
    cache = _engines.__dict__.setdefault("dis", {})
    key = (preset, finest_scale, refinement, started)
    if key not in cache:
        dis = cv2.DISOpticalFlow_create(PRESETS[preset])  # type: ignore[attr-defined]
        if finest_scale is not None:
            dis.setFinestScale(finest_scale)
        if refinement is not None:
            dis.setVariationalRefinementIterations(refinement)
        cache[key] = dis
    return cache[key]


def _polisher(iterations: int) -> cv2.VariationalRefinement:
    """Return this thread's variational refinement of ``iterations`` fixed-point steps."""
    cache = _engines.__dict__.setdefault("polish", {})
    if iterations not in cache:
        refine = cv2.VariationalRefinement_create()  # type: ignore[attr-defined]
        refine.setFixedPointIterations(iterations)
        cache[iterations] = refine
    return cache[iterations]


#: The flow is measured on frames downscaled to at most this width (0: full size).
FLOW_WIDTH = 960


def optical_flow(a: np.ndarray, b: np.ndarray, preset: str = "medium",
                 max_width: int = FLOW_WIDTH, finest_scale: int | None = None,
                 refinement: int | None = None, polish: int = 0,
                 expect: np.ndarray | None = None, entering: bool = False) -> np.ndarray:
    """Dense flow ``F`` with ``a(s) ~ b(s + F(s))`` (DIS, OpenCV).

    Where zero motion matches a textured region clearly better than DIS from zero, the
    region keeps still (:func:`_still_where_it_matches`).

    Where the frame's global translation (:func:`global_shifts`) is large
    (:data:`LARGE_MOTION`), DIS runs a second time starting from it, and each pixel keeps
    the run whose flow matches ``b`` better over a patch around it: a whip pan over grass
    or brick is then followed instead of an alias of its texture. Where the copies
    overlap far better at another shift than the cyclic correlation's (a pan of more
    than half the width a frame, read as its alias the other way), DIS runs from that
    one too, unless ``expect`` is given. With ``expect`` (a
    translation the neighbouring pair measured), DIS runs again from it too, used where
    it matches ``b`` better over the frame as a whole (the median patch cost: content
    entering and leaving matches under no flow), then pixel by pixel: over a flat sky
    the phase correlation can miss a fast pan the pairs around follow, and DIS follow a
    near pole, all that two frames share, or one lattice taken for another.

    Parameters
    ----------
    a, b : ndarray of shape (H, W), 0-255
        Grey frames.
    preset : str
        DIS preset.
    max_width : int
        Compute on frames downscaled to at most this width (0: full size).
    finest_scale : int, optional
        DIS finest pyramid level (0 = full resolution); default the preset's, or 0 for
        ``medium`` on (downscaled) frames up to 480 px wide.
    refinement : int, optional
        Variational refinement iterations at each pyramid level; default the preset's.
    polish : int
        Then this many fixed-point iterations of variational refinement
        (``cv2.VariationalRefinement``) on the (downscaled) frames' full resolution: DIS
        at finest scale 1 so polished costs half of DIS at scale 0, for 0.1 dB on the
        research pairs (``docs/history/measurements.md``).
    expect : ndarray of shape (2,), optional
        A translation ``(dx, dy)`` (full-resolution pixels) to start DIS from as well.
    entering : bool
        Where the global translation is large, the pixels it carries outside ``b``
        (content entering the frame) whose flow nothing confirms take the translation
        (:func:`~unjello.motion.flow.patches.unmatched_entering`): for a pair no earlier
        pair's pace guides.

    Returns
    -------
    ndarray of shape (H, W, 2), float32
        ``(dx, dy)`` in full-resolution pixels.
    """
    h, w = a.shape
    scale = min(1.0, max_width / w) if max_width else 1.0
    a8 = np.clip(a, 0, 255).astype(np.uint8)
    b8 = np.clip(b, 0, 255).astype(np.uint8)
    if scale < 1.0:
        size = (max(8, round(w * scale)), max(8, round(h * scale)))
        a8 = cv2.resize(a8, size, interpolation=cv2.INTER_AREA)
        b8 = cv2.resize(b8, size, interpolation=cv2.INTER_AREA)
    if finest_scale is None and preset == "medium" and a8.shape[1] <= _FULL_RES_WIDTH:
        finest_scale = 0  # the preset's level 1 would be coarser than on larger frames
    dis = _engine(preset, finest_scale, refinement)
    flow = _still_where_it_matches(a8, b8, dis.calc(a8, b8, None))  # type: ignore[call-overload]
    def started(shift: np.ndarray, whole: Literal["mean", "median"] | None) -> np.ndarray:
        """DIS again from the translation ``shift``, kept where it matches better."""
        start = np.empty_like(flow)
        start[...] = shift
        again = _engine(preset, finest_scale, refinement, started=True)
        return _pick_by_cost(a8, b8, flow, again.calc(a8, b8, start), whole=whole)

    shifts = global_shifts(a8, b8)
    if expect is not None:  # the pace around: over a flat sky, a near pole's shift can
        shifts = shifts[:1]  # lay the copies on each other best, and DIS follow it
    for shift, response in shifts:
        if np.hypot(*shift) >= LARGE_MOTION * a8.shape[1]:
            flow = started(shift, whole="mean" if response < _SHIFT_RESPONSE else None)
    best = shifts[-1][0]
    if entering and np.hypot(*best) >= LARGE_MOTION * a8.shape[1]:
        flow[unmatched_entering(a8, b8, flow, best, _PICK_PATCH)] = best
    if expect is not None:
        flow = started(np.asarray(expect, np.float32) * scale, whole="median")
    if polish > 0:
        _polisher(polish).calc(a8, b8, flow)
    if scale < 1.0:
        sx, sy = w / a8.shape[1], h / a8.shape[0]
        flow = cv2.resize(flow, (w, h), interpolation=cv2.INTER_LINEAR)
        flow[..., 0] *= sx
        flow[..., 1] *= sy
    return flow


def landing(flow: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where each pixel's flow lands (x, y), and whether that is inside the frame."""
    return grid_plus(flow)


def consistent(fwd: np.ndarray, bwd: np.ndarray, tol: float) -> np.ndarray:
    """Pixels whose flow lands inside the frame and comes back within ``tol`` px."""
    return consistency(np.ascontiguousarray(fwd, np.float32),
                       np.ascontiguousarray(bwd, np.float32), float(tol))


def median_along(values: np.ndarray, axis: int = -1) -> np.ndarray:
    """``np.median(values, axis)`` of values without NaN, by one partition of a copy.

    The same numbers (the two middle values' mean where the count is even) in a third of
    the time on the working grid's summaries: one partition at the middle, where NumPy's
    median partitions at both middle values (0.57 against 0.19 ms for 270 rows of 80
    flow vectors, 0.81 against 0.24 for 120).

    Examples
    --------
    >>> median_along(np.array([[3.0, 1.0, 2.0, 10.0], [5.0, 4.0, 6.0, 7.0]]), axis=1).tolist()
    [2.5, 5.5]
    """
    v = np.ascontiguousarray(np.moveaxis(values, axis, -1))
    n = v.shape[-1]
    k = n // 2
    part = np.partition(v, k, axis=-1)
    if n % 2:
        return part[..., k]
    return (part[..., :k].max(axis=-1) + part[..., k]) * 0.5  # below k: the k-1'th is the largest


def _shorth(values: np.ndarray) -> np.ndarray:
    """Centre of the densest half of each row's values (NaN = missing), per channel.

    The midpoint of the shortest interval holding half the samples (the "shorth") follows
    the dominant motion of a row even when an independently moving object covers much of
    it, where a median would be pulled towards the object.

    Parameters
    ----------
    values : ndarray of shape (rows, n, c)

    Returns
    -------
    ndarray of shape (rows, c)
    """
    return shorth_sorted(np.sort(values, axis=1))  # NaN last


def row_flows(flow: np.ndarray, ok: np.ndarray, agree: float | None = None
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Dominant flow of every row with enough reliable pixels.

    Parameters
    ----------
    flow : ndarray of shape (h, w, 2)
        Flow from a frame to its previous one.
    ok : ndarray of bool, shape (h, w)
        Reliable pixels.
    agree : float, optional
        Weigh each row by the share of its pixels whose reliable flow is within this
        many pixels of the row's, on both axes (:data:`ROW_AGREE`), instead of the share
        that is reliable: a flat region or content entering the frame passes the
        consistency check with any flow, which then outvotes the scene's in few rows.

    Returns
    -------
    rows : ndarray of shape (m,)
        Row indices (float).
    flow : ndarray of shape (m, 2)
        The row's flow (:func:`_shorth` of its reliable pixels).
    weight : ndarray of shape (m,)
        Fraction of the row's pixels that were reliable (that agree, with ``agree``).
    """
    h, w = ok.shape
    count = ok.sum(axis=1)
    use = count >= max(8, 0.15 * w)
    if not use.any():
        return np.zeros(0), np.zeros((0, 2)), np.zeros(0)
    # The shorth sorts every row: a hundred and more samples per row are plenty.
    stride = max(1, w // 160)
    vals = np.where(ok[use, ::stride, None], flow[use, ::stride], np.nan)
    rows, med = np.flatnonzero(use).astype(np.float64), _shorth(vals)
    if agree is None:
        return rows, med, count[use] / w
    near = (np.abs(vals - med[:, None, :]) <= agree).all(axis=2)  # NaN: False
    return rows, med, near.sum(axis=1) / vals.shape[1]


def half_row_flows(flow: np.ndarray, ok: np.ndarray
                   ) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """Rows and row flows (:func:`row_flows`) of the left and of the right half."""
    half = flow.shape[1] // 2
    left, right = (row_flows(flow[:, c], ok[:, c])[:2]
                   for c in (slice(0, half), slice(half, None)))
    return left, right


@dataclass(frozen=True)
class FlowSettings:
    """How the flow between two frames is computed and checked (:func:`flow_pair`).

    Parameters
    ----------
    preset : {'ultrafast', 'fast', 'medium'}
        DIS preset.
    finest_scale : int, optional
        DIS finest pyramid level (:func:`optical_flow`).
    refinement : int, optional
        Variational refinement iterations of the ``medium`` preset (``None``: the
        preset's own).
    consistency : float
        Forward-backward disagreement (px) above which a pixel is unreliable.
    edge_refine : bool
        Sharpen the flow at motion boundaries (:func:`refine_motion_edges`).
    polish : int
        Variational refinement iterations at full resolution after DIS (``medium``
        preset only; :func:`optical_flow`).
    fallback : FlowSettings, optional
        The flow measured instead for a pair that this one does not explain
        (:func:`explains`): a cheap flow where it is good enough, a fine one where not.
    """

    preset: str = "medium"
    finest_scale: int | None = None
    refinement: int | None = 1
    consistency: float = 3.0
    edge_refine: bool = False
    polish: int = 0
    fallback: FlowSettings | None = None

    def __post_init__(self) -> None:
        if self.preset not in PRESETS:
            raise SettingsError(f"flow preset must be one of {', '.join(PRESETS)}, "
                                f"got {self.preset!r}")


def flow_pair(prev: np.ndarray, cur: np.ndarray, settings: FlowSettings, max_width: int = 0,
              two_way: bool = False, expect: np.ndarray | None = None,
              entering: bool = False
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Flows between two frames both ways, each with its forward-backward check.

    The flow from ``cur`` to ``prev`` is computed (DIS); the other way is its inverse
    (:func:`invert_flow`), a fraction of the cost of a second flow (and as good on the
    research pairs). With ``two_way`` the other way is a second DIS flow: an independent
    check that rejects more wrong flow (the readout estimate needs it), at twice the cost.
    A flow that does not explain the pair (:func:`explains`) is measured again with the
    settings' ``fallback``. ``expect``: a translation of ``cur`` to ``prev`` to start the
    flow from as well; ``entering``: check where content enters (both :func:`optical_flow`).

    Returns
    -------
    bwd, bwd_ok : ndarray
        Flow from ``cur`` to ``prev`` and its reliable pixels.
    fwd, fwd_ok : ndarray
        Flow from ``prev`` to ``cur`` and its reliable pixels.
    """
    medium = settings.preset == "medium"
    refinement = settings.refinement if medium else None
    polish = settings.polish if medium else 0
    bwd = optical_flow(cur, prev, settings.preset, max_width, settings.finest_scale,
                       refinement, polish, expect, entering)
    if settings.fallback is not None and not explains(prev, cur, bwd):
        return flow_pair(prev, cur, settings.fallback, max_width, two_way, expect, entering)
    if settings.edge_refine:
        bwd = refine_motion_edges(np.asarray(cur, np.float32), np.asarray(prev, np.float32),
                                  bwd)
    fwd = (optical_flow(prev, cur, settings.preset, max_width, settings.finest_scale,
                        refinement, polish)
           if two_way else invert_flow(bwd, images=(prev, cur)))
    bwd_ok = consistent(bwd, fwd, settings.consistency)
    return bwd, bwd_ok, fwd, consistent(fwd, bwd, settings.consistency)


def misses(prev: np.ndarray, cur: np.ndarray, flow: np.ndarray) -> np.ndarray:
    """Pixels of ``cur`` that a flow to ``prev`` carries onto grey levels unlike their own.

    The absolute difference of ``cur`` and ``prev`` brought back by the flow, blurred (a
    Gaussian of 2 px), above :data:`_PHOTO_LEVEL` grey levels or four times its median;
    pixels whose flow lands outside the frame are not counted (bool, shape (h, w)). One
    remap and a blur: about 1 ms on a 480 x 270 copy.

    Parameters
    ----------
    prev, cur : ndarray of shape (h, w)
        The frames (grey, 0-255).
    flow : ndarray of shape (h, w, 2)
        Flow from ``cur`` to ``prev`` (``cur(s) ~ prev(s + flow(s))``), in their pixels.
    """
    gx, gy, inside = landing(flow)
    seen = cv2.remap(np.asarray(prev, np.float32), gx, gy, cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_REPLICATE)
    miss = cv2.GaussianBlur(cv2.absdiff(np.asarray(cur, np.float32), seen), (0, 0), 2.0)
    level = max(_PHOTO_LEVEL, 4.0 * float(median_along(miss[::4, ::4].ravel())))
    return (miss > level) & inside


def explains(prev: np.ndarray, cur: np.ndarray, flow: np.ndarray) -> bool:
    """Whether a flow from ``cur`` to ``prev`` explains the pair well enough to be used.

    A smooth flow passes its own forward-backward check even where it is wrong: on a
    spinning object, whose blades it follows with a plausible motion of their
    surroundings. That shows as pixels the flow carries onto grey levels unlike their
    own (:func:`misses`): at most :data:`PHOTO_MISS` of the frame may.

    Parameters
    ----------
    prev, cur : ndarray of shape (h, w)
        The frames (grey, 0-255).
    flow : ndarray of shape (h, w, 2)
        Flow from ``cur`` to ``prev`` (``cur(s) ~ prev(s + flow(s))``), in their pixels.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> b = cv2.GaussianBlur(rng.uniform(0, 255, (60, 80)).astype(np.float32), (0, 0), 1)
    >>> a = np.roll(b, -3, axis=1)  # a(s) = b(s + (3, 0))
    >>> right = np.zeros((60, 80, 2), np.float32); right[..., 0] = 3
    >>> wrong = right.copy(); wrong[20:40, 30:50] = 0  # a patch it does not follow
    >>> explains(b, a, right), explains(b, a, wrong)
    (True, False)
    """
    h, w = cur.shape
    return float(np.count_nonzero(misses(prev, cur, flow))) <= PHOTO_MISS * h * w
