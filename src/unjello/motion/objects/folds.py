"""Do no harm, step one: find where a per-pixel correction folds or tears the picture.

The dense method moves every pixel ``s`` to ``p = s - D(s)``. Where the motion was
measured right, that map is smooth: a rolling-shutter correction shears and stretches a
frame by a few percent, it does not turn it inside out. Where optical flow failed -- a
fast-spinning propeller or fidget spinner, a wheel, aliased texture -- the map *folds*
(two pixels land on one place: the Jacobian determinant of ``s -> p`` is at or below zero)
or *tears* (neighbouring pixels fly apart: the determinant is several times one), and the
warped frame shows melted, torn objects that look worse than the input.

:func:`map_jacobian` measures the map. A correct map folds too, but only along occlusion
edges (where a nearer object covers what is behind it): lines a pixel or two wide. Failed
motion folds and tears in blobs. :func:`fold_share` counts the pixels of such blobs, so
that a frame the correction may have damaged is reported, not hidden. (Keeping those
places on the camera's motion was tried and cost the research pairs 0.1-0.9 dB:
``docs/tuning.md``.)
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import cv2
import numpy as np

from ..._kernels.pixelwise import jacobian_det

__all__ = ["FOLD", "TEAR", "map_jacobian", "fold_share", "fold_blobs", "failed_blobs",
           "fill_hull", "fill_holes", "whole_object", "object_islands", "keep_whole",
           "unlike_neighbours", "followed_objects", "ISLAND_MISSED", "REACH"]

#: A pixel whose neighbourhood the map squeezes to less than this share of its area is a
#: fold (at 0 or below: turned over); one it stretches to more than ``TEAR`` times, a tear.
FOLD, TEAR = 0.25, 4.0

#: An island (:func:`object_islands`) whose flow failed its check on at least this share of
#: its pixels is kept whole with the folds (:func:`keep_whole`).
ISLAND_FAILED = 0.2

#: A piece of changing motion that touches the frame's border along more than this share
#: of its length is the view itself (parallax of a road or a wall), not an object.
_BORDER_CONTACT = 0.08

#: An island is one the flow cannot follow (a spinner) only where the flow lands this share
#: of it, in blobs, on unlike grey levels all round (``docs/tuning.md#island_missed``).
ISLAND_MISSED = 0.05

#: Distance (px, at the working resolution) over which failed flow joins a blob's region
#: (:func:`keep_whole`) and an object's pieces join (:func:`object_islands`).
REACH = 24

#: Grey levels (0-255, blurred) by which a pixel must differ from both neighbours, moved
#: by the camera, to move on its own (:func:`unlike_neighbours`) ...
CHANGE_LEVEL = 12.0
#: ... not told where the camera moves more than this share of the width between the
#: frames: the whip pans over texture lost 0.003-0.007x with such islands kept whole.
CHANGE_PAN = 0.05

#: The camera motion's weight in a kept region's fill against its surroundings' (0.5 at the
#: edge, 1e-4 about four ``reach`` inside; ``docs/tuning.md#_camera_weight``).
_CAMERA_WEIGHT = 1e-4



def map_jacobian(field: np.ndarray) -> np.ndarray:
    """Jacobian determinant of the map ``p = s - field(s)`` at every pixel.

    Parameters
    ----------
    field : ndarray of shape (h, w, 2)
        Per-pixel displacement ``D`` (``x``, ``y``).

    Returns
    -------
    ndarray of shape (h, w), float32
        ``det(I - grad D)``: 1 for a translation, below 0 where the map folds over.

    Examples
    --------
    >>> f = np.zeros((4, 5, 2), np.float32); f[..., 0] = 0.5 * np.arange(5)
    >>> float(map_jacobian(f)[2, 2])
    0.5
    """
    return jacobian_det(np.ascontiguousarray(field, np.float32))  # np.gradient's differences


def fold_blobs(field: np.ndarray, followed: np.ndarray | None = None, reach: int = REACH
               ) -> np.ndarray:
    """Pixels in blobs where the map folds or tears (bool, shape (h, w)).

    Pixels whose determinant is below :data:`FOLD` or above :data:`TEAR` and that survive
    an opening by a 3x3 disc (so not the thin lines of a correct map's occlusion edges).
    With ``followed`` (objects that move on their own and that the flow follows,
    :func:`followed_objects`), not those within ``reach`` of one: they are where a near
    object covers what is behind it (parallax), as they should be.
    """
    det = map_jacobian(field)
    bad = ((det < FOLD) | (det > TEAR)).astype(np.uint8)
    found = cv2.morphologyEx(bad, cv2.MORPH_OPEN,
                             cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (3, 3))).astype(bool)
    if followed is not None and followed.any():
        found &= ~cv2.dilate(followed.astype(np.uint8), _disc(reach)).astype(bool)
    return found


def fold_share(field: np.ndarray, followed: np.ndarray | None = None) -> float:
    """Share of pixels in blobs where the map folds or tears (:func:`fold_blobs`).

    Examples
    --------
    >>> f = np.zeros((40, 40, 2), np.float32)
    >>> f[10:20, 10:20, 0] = 8 * np.arange(10)  # a patch turned over: a fold
    >>> 0.05 < fold_share(f) < 0.1, fold_share(np.zeros((40, 40, 2)))
    (True, 0.0)
    """
    return float(fold_blobs(field, followed).mean())


def fill_hull(out: np.ndarray, piece: np.ndarray, value: int = 1) -> None:
    """Paint the convex hull of the pixels of ``piece`` (bool) into ``out`` with ``value``.

    An object found in patches (failed flow, what moves) stands for itself as one piece.
    """
    ys, xs = np.nonzero(piece)
    cv2.fillConvexPoly(out, cv2.convexHull(np.stack([xs, ys], axis=1).astype(np.int32)), value)


#: A cluster of failed flow is an object where it covers at least this share of the frame,
BLOB_SHARE = 0.003


#: ... with at least this share of its pixels failed ...
BLOB_DENSITY = 0.2


#: ... and only this many of the largest are candidates.
BLOB_MOST = 3


def failed_blobs(unreliable: np.ndarray, *, min_share: float = BLOB_SHARE,
                 density: float = BLOB_DENSITY, most: int = BLOB_MOST,
                 followed: np.ndarray | None = None,
                 missed: np.ndarray | None = None) -> np.ndarray:
    """Objects where the flow failed its check on many pixels (bool, shape (h, w)).

    A fast-spinning object often does not fold the map: the flow settles on a plausible
    wrong motion (an alias of its symmetry) or on its surroundings', and fails the
    consistency check in patches all over the object. Patches closer than a tenth of
    the width are joined, and each cluster -- at least ``min_share`` of the frame, with at
    least ``density`` of its pixels failed -- stands for the object as its convex hull, a
    candidate for :func:`unjello.motion.objects.spinners.keep_spinning`; the ``most`` largest are
    returned. A cluster beside an object the flow follows (within :data:`REACH` px of
    ``followed``, :func:`followed_objects`) whose pixels the flow explains (less than
    :data:`ISLAND_MISSED` of them ``missed``) is left out: its failures are occlusions,
    the near object's edges.

    Examples
    --------
    >>> bad = np.zeros((100, 100), bool); bad[20:50:2, 20:50] = True  # half failed
    >>> int(failed_blobs(bad).sum()) > 800, bool(failed_blobs(np.zeros((9, 9), bool)).any())
    (True, False)
    """
    h, w = unreliable.shape
    bad = unreliable.astype(np.uint8)
    size = max(9, w // 10) | 1
    k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))
    closed = cv2.morphologyEx(cv2.morphologyEx(bad, cv2.MORPH_CLOSE, k), cv2.MORPH_OPEN,
                              cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (9, 9)))
    count, labels, stats, _ = cv2.connectedComponentsWithStats(closed)
    out = np.zeros((h, w), np.uint8)
    big = [i for i in range(1, count) if stats[i, cv2.CC_STAT_AREA] >= min_share * h * w]
    big.sort(key=lambda i: -stats[i, cv2.CC_STAT_AREA])
    beside = None if followed is None or missed is None else cv2.dilate(
        followed.astype(np.uint8), _disc(REACH)).astype(bool)
    for i in big[:most]:
        blob = labels == i
        if unreliable[blob].mean() >= density and (
                beside is None or missed is None or not beside[blob].any()
                or missed[blob].mean() >= ISLAND_MISSED):
            fill_hull(out, blob)
    return out.astype(bool)


#: Width (px, a Gaussian's) of the blend from a kept region to the field around it.
FEATHER = 12.0


#: A kept region's blend is repeated at most this many times while folds remain.
PASSES = 3


def keep_whole(field: np.ndarray, camera: np.ndarray, unreliable: np.ndarray, *,
               changing: np.ndarray | None = None, islands_only: bool = False,
               carried: np.ndarray | None = None, from_folds: bool = True,
               followed: np.ndarray | None = None, reach: int = REACH,
               feather: float = FEATHER, passes: int = PASSES
               ) -> tuple[np.ndarray, float, float, np.ndarray]:
    """Give the places where the map folds or tears in blobs the motion around them.

    A blob of folds marks motion that cannot be right; the failed flow around it (pixels
    whose flow failed its check, ``unreliable``, within ``reach`` px) belongs to the same
    object, so it goes too. There the field becomes the motion of the region's
    surroundings: its rows' camera motion, plus the field outside it beyond theirs (a
    normalised Gaussian average, ``reach`` px; nothing where nothing is near): a spinner
    on a still floor is shown as the sensor saw it, a patch of a fast pan moves with the
    pan, neither torn. The weight falls off smoothly (a Gaussian of ``feather`` px) so
    that the seam does not tear.

    Parameters
    ----------
    field : ndarray of shape (h, w, 2)
        Per-pixel displacement.
    camera : ndarray of shape (h, 2)
        The camera's displacement per scanline (eq. 26).
    unreliable : ndarray of bool, shape (h, w)
        Pixels whose flow failed its consistency check.
    changing : ndarray of bool, shape (h, w), optional
        Pixels unlike both neighbours under the camera's motion: an object that moves
        on its own is kept whole with them (:func:`whole_object`).
    islands_only : bool
        Only the folds inside such an object, one that does not reach the border, count
        (a map that folds a little elsewhere folds along occlusions: left alone).
    carried : ndarray of bool, shape (h, w), optional
        The previous frame's regions kept whole: an island on one of them whose flow
        failed on :data:`ISLAND_FAILED` of it seeds too (a spinning object keeps
        spinning, though this frame's map may not fold: the clip's last frame, seen
        from one side).
    from_folds : bool
        Whether the blobs of folds seed at all (False: only ``carried`` islands).
    followed : ndarray of bool, shape (h, w), optional
        Objects moving on their own that the flow follows (:func:`followed_objects`):
        blobs of folds within ``reach`` of them neither seed nor count (:func:`fold_blobs`).
    reach, feather : float
        Distance (px) over which failed flow joins a blob's region, and the blend's width.
    passes : int
        A blend can leave new folds at its seam; the pass repeats while blobs remain, at
        most this many times.

    Returns
    -------
    field : ndarray of shape (h, w, 2)
    kept : float
        Share of pixels whose motion changed (by more than 0.01 px).
    folds : float
        :func:`fold_share` of the returned field (with ``followed``).
    regions : ndarray of bool, shape (h, w)
        The places given their surroundings' motion (every pass's), each an object whose
        motion failed: :func:`unjello.motion.objects.spinners.keep_spinning` may fit them a
        rotation.
    """
    islands = object_islands(changing, reach)
    # Where the frame folds in blobs anyway, an island whose flow failed on much of it
    # cannot be trusted either (a second spinner, torn without folding): it all seeds;
    # so does one on an object kept whole in the frame before.
    failed = np.zeros(field.shape[:2], bool)
    if islands is not None and (carried is not None or not islands_only):
        count, labels = cv2.connectedComponents(islands.astype(np.uint8))
        share = (np.bincount(labels[unreliable], minlength=count)
                 / np.maximum(np.bincount(labels.ravel(), minlength=count), 1))
        bad = share >= ISLAND_FAILED
        if carried is not None and (islands_only or not from_folds):
            bad &= np.bincount(labels[carried], minlength=count) > 0
        failed = np.isin(labels, np.flatnonzero(bad)) & islands

    def blobs(f: np.ndarray) -> np.ndarray:
        found = fold_blobs(f, followed, reach) if from_folds else np.zeros(f.shape[:2], bool)
        if islands_only and islands is not None:
            found &= islands
        return found | failed

    out, seeds = field, blobs(field)
    regions = np.zeros(field.shape[:2], bool)
    for _ in range(passes):
        if not seeds.any():
            break
        out, region = _keep_once(out, seeds, camera, unreliable, changing, reach, feather)
        regions |= region
        seeds = blobs(out) & ~regions
    changed = np.abs(out - field).max(axis=-1) > 0.01
    return out, float(changed.mean()), float(seeds.mean()), regions


def _disc(radius: int) -> np.ndarray:
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * radius + 1, 2 * radius + 1))


def fill_holes(mask: np.ndarray) -> np.ndarray:
    """Return ``mask`` (bool) with what it encloses filled (what the border cannot reach)."""
    h, w = mask.shape
    pad = np.zeros((h + 2, w + 2), np.uint8)
    pad[1:-1, 1:-1] = mask
    flood = pad.copy()
    cv2.floodFill(flood, np.zeros((h + 4, w + 4), np.uint8), (0, 0), 1)
    return (pad | (1 - flood))[1:-1, 1:-1].astype(bool)


def whole_object(seeds: np.ndarray, reach: int, changing: np.ndarray | None
                 ) -> np.ndarray:
    """Return the whole objects the blobs of folds ``seeds`` lie on (bool, filled).

    Each piece of ``changing`` (unlike both neighbours under the camera's motion: what
    moves on its own; closed by a disc of ``reach / 2``) that touches a seed and barely
    the frame's border (:func:`object_islands`) is an object: a spinner on a table is
    one such island, arms, rings and all, where parallax (a road, a wall that moves
    against the camera's model) runs along the border and is left out. With what it
    encloses (its hub, a ring's face: they may look still).
    """
    islands = object_islands(changing, reach)
    if islands is None:
        return np.zeros(seeds.shape, bool)
    return fill_holes(_touching(islands, seeds))


def object_islands(changing: np.ndarray | None, reach: int) -> np.ndarray | None:
    """Return the pieces of ``changing`` (closed) that barely reach the frame's border.

    A piece touching the border along more than :data:`_BORDER_CONTACT` of its length
    (parallax of a road or a wall, the whole view) is left out; an object near the
    border, its noise joining it there, is kept.
    """
    if changing is None:
        return None
    closed = cv2.morphologyEx(changing.astype(np.uint8), cv2.MORPH_CLOSE,
                              _disc(max(1, reach // 2)))
    count, labels = cv2.connectedComponents(closed)
    ring = np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]])
    contact = np.bincount(ring, minlength=count)
    # A piece that touches the border along more than this share of it is no island.
    wide = np.flatnonzero(contact > _BORDER_CONTACT * ring.size)
    return (labels > 0) & ~np.isin(labels, wide)


def followed_objects(changing: np.ndarray | None, missed: np.ndarray, reach: int = REACH
                     ) -> np.ndarray | None:
    """Return the objects moving on their own that the flow follows (bool, shape (h, w)).

    What moves on its own (``changing``, :func:`unlike_neighbours`) is either an object
    the flow cannot follow -- a spinner, whose pixels the flow carries onto grey levels
    unlike their own (``missed``) in blobs -- or one it follows at a speed of its own: a
    near object in parallax, a car, whose misses are thin lines along its edges (where it
    covers what is behind it). The pieces of ``changing`` (closed as in
    :func:`object_islands`) with less than :data:`ISLAND_MISSED` of their pixels missed
    are the latter: they keep their own motion.

    Parameters
    ----------
    changing : ndarray of bool, shape (h, w), or None
        Pixels unlike both neighbours under the camera's motion.
    missed : ndarray of bool, shape (h, w)
        Pixels the flow to every neighbour carries onto unlike grey levels, opened (blobs
        only): :func:`unjello.motion.flow.dis.misses`.
    reach : int
        As in :func:`keep_whole`.

    Examples
    --------
    >>> changing = np.zeros((60, 80), bool); changing[10:30, 10:30] = changing[10:50, 50:60] = True
    >>> missed = np.zeros((60, 80), bool); missed[12:28, 12:28] = True  # the first fails
    >>> followed = followed_objects(changing, missed, 8)
    >>> bool(followed[20, 20]), bool(followed[30, 55])
    (False, True)
    """
    if changing is None:
        return None
    closed = cv2.morphologyEx(changing.astype(np.uint8), cv2.MORPH_CLOSE,
                              _disc(max(1, reach // 2)))
    count, labels = cv2.connectedComponents(closed)
    share = (np.bincount(labels[missed], minlength=count)
             / np.maximum(np.bincount(labels.ravel(), minlength=count), 1))
    keep = share < ISLAND_MISSED
    keep[0] = False
    return keep[labels]


def _touching(mask: np.ndarray, seeds: np.ndarray) -> np.ndarray:
    """Return the connected pieces of ``mask`` that a seed lies on."""
    count, labels = cv2.connectedComponents(mask.astype(np.uint8))
    on = np.unique(labels[seeds & (labels > 0)])
    return np.isin(labels, on[on > 0])


def _keep_once(field: np.ndarray, seeds: np.ndarray, camera: np.ndarray,
               unreliable: np.ndarray, changing: np.ndarray | None, reach: int,
               feather: float) -> tuple[np.ndarray, np.ndarray]:
    """One pass of :func:`keep_whole` around the blobs ``seeds``: the field, the region.

    A seed on an island (:func:`whole_object`) takes the whole object with a margin of
    ``reach / 3`` and blends out over ``feather`` px beyond it, so no seam crosses the
    object. Any other seed takes the failed flow within ``reach`` of it, closed by a
    7 px disc, blended over 6 px (as before islands were known: the whip pans over
    texture, whose folds are on no island, were measured so).
    """
    k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (7, 7))
    obj = cv2.dilate(whole_object(seeds, reach, changing).astype(np.uint8),
                     _disc(max(1, reach // 3)))
    rest = seeds & ~obj.astype(bool)
    near = cv2.dilate(rest.astype(np.uint8), _disc(reach)).astype(bool)
    patch = cv2.morphologyEx((rest | (near & unreliable)).astype(np.uint8), cv2.MORPH_CLOSE, k)
    weight = np.maximum(
        cv2.GaussianBlur(cv2.dilate(patch, k).astype(np.float32), (0, 0), 6.0),
        cv2.GaussianBlur(cv2.dilate(obj, _disc(int(feather))).astype(np.float32), (0, 0),
                         feather) if obj.any() else 0.0)
    region = patch.astype(bool) | obj.astype(bool)
    weight = np.maximum(weight, region.astype(np.float32))[..., None]
    # What fills the region: its rows' camera motion plus its surroundings' beyond the
    # camera's (a normalised Gaussian average of the field outside it, less their rows'
    # camera motion: in a fast pan each row moves by its own time, and an average over
    # the rows around took the bottom of the frame by half its displacement). Deep inside
    # a large region, where the surroundings weigh little, the camera's motion takes over
    # -- gradually: switched at a threshold, the two differed by a few px along a line
    # across the objects (the real spinners' creases).
    outside = (weight[..., 0] < 0.01).astype(np.float32)
    sigma = float(reach)
    den = cv2.GaussianBlur(outside, (0, 0), sigma)[..., None]
    cam = np.broadcast_to(camera[:, None, :], field.shape)
    num = cv2.GaussianBlur(np.ascontiguousarray((field - cam) * outside[..., None], np.float32),
                           (0, 0), sigma)
    fill = cam + num / (den + _CAMERA_WEIGHT)
    out = field * (1.0 - weight) + fill * weight
    return out.astype(field.dtype), region


def unlike_neighbours(image: np.ndarray, others: Sequence[tuple[np.ndarray, float]],
                      c_at: Callable[[np.ndarray], np.ndarray], t_rows: np.ndarray
                      ) -> np.ndarray | None:
    """Pixels unlike both neighbours brought over by the camera's motion (bool).

    Each neighbour is moved by the camera's displacement between the two frames'
    scanline times and compared; what differs from both (blurred, above
    :data:`CHANGE_LEVEL` grey levels or four times the frame's median difference) moves
    on its own: a spinning object shows as a whole, arms, rings and all, where its
    flow's failures are only patches. None without a neighbour, or in a fast pan
    (:data:`CHANGE_PAN`).

    Parameters
    ----------
    image : ndarray of shape (h, w)
        The frame (grey).
    others : sequence of (ndarray, float)
        Its neighbours and their start times relative to its own.
    c_at : callable
        The camera's path: ``c_at(t)`` -> shape ``t.shape + (2,)``, times relative to the
        frame's start.
    t_rows : ndarray of shape (h,)
        The frame's scanline times, relative to its start.
    """
    h, w = image.shape
    rows = np.arange(h, dtype=np.float32)[:, None]
    cols = np.arange(w, dtype=np.float32)[None, :]
    diffs = []
    for other, dt in others:
        d = (c_at(t_rows + dt) - c_at(t_rows)).astype(np.float32)
        if float(np.abs(d).max()) > CHANGE_PAN * w:
            return None  # a fast pan: the camera's model leaves too much to tell by
        mx = np.ascontiguousarray(np.broadcast_to(cols + d[:, :1], (h, w)))
        my = np.ascontiguousarray(np.broadcast_to(rows + d[:, 1:], (h, w)))
        seen = cv2.remap(np.asarray(other, np.float32), mx, my, cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_REPLICATE)
        diffs.append(np.abs(np.asarray(image, np.float32) - seen))
    if not diffs:
        return None
    diff = cv2.GaussianBlur(np.minimum.reduce(diffs), (0, 0), 2.0)
    return diff > max(CHANGE_LEVEL, 4.0 * float(np.median(diff)))
