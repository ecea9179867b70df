"""Background a nearer object uncovered, taken from the neighbour that saw it.

Inside the frame, a nearer object moving across its background (parallax) covered, when a
row was read, background the reference time shows beside it: the maps stretch the
object's edge over it, and :func:`uncovered` takes it from the neighbour that saw it
instead (:func:`confirmed` checks it on the picture, :func:`uncovered_sources` places it
on a plane).
"""

from __future__ import annotations

import cv2
import numpy as np

from ...timing import pixel_grid
from .neighbours import sample_points

__all__ = ["uncovered", "uncovered_sources", "confirmed", "SETTLED", "REACH", "UNIFORM",
           "GROUP", "AGREE"]

#: A backward map whose source's own displacement differs from the map's by more than
#: this (pixels of the maps' grid) has not settled on one surface.
SETTLED = 2.0
#: Farthest (pixels of the maps' grid) that an uncovered pixel's background is looked for.
REACH = 12
#: Rows whose displacement departs from their median by more than this share of it (the median
#: departure) are left alone. (``docs/tuning.md#uniform``)
UNIFORM = 0.1
#: Fewest pixels of the grid, side by side, taken as uncovered background.
GROUP = 6
#: Largest grey-level difference (over channels) between what the two neighbours show
#: at an uncovered pixel for them to agree on its background (:func:`confirmed`).
AGREE = 20.0
#: The eight directions, and the steps (px) along each, searched for the background
#: beside an uncovered pixel.
_DIRECTIONS, _STEPS = (
    np.array([(0, 1), (0, -1), (1, 0), (-1, 0), (1, 1), (1, -1), (-1, 1), (-1, -1)]),
    np.array([1, 2, 3, 4, 6, 8, REACH]))


def uncovered(maps: tuple[np.ndarray, np.ndarray], field: np.ndarray, flows: list[np.ndarray],
              offsets: list[int], reference_row: float, lone: bool = False,
              here: bool = False) -> tuple[np.ndarray, ...] | None:
    """Output pixels showing background that a nearer object covered in this frame.

    A near object (a pole passing in front of a pan) moves across its background:
    between the time a row was read and the reference time it uncovers background on
    one side. The frame never saw it there: no source pixel lands on it, and the
    backward maps do not settle (their source's own displacement differs from theirs
    by more than :data:`SETTLED` px along the row's motion); drawn, the object shows
    wider than it is. The background goes on moving as around it: each such pixel
    takes the displacement of the settled pixel within :data:`REACH` (along eight
    directions) nearest its row's median (the background's, where the object is
    narrow), in rows that move as one (:data:`UNIFORM`: a pan over a far background,
    not forward motion). Where that displacement leads to a source that moves
    otherwise (the object, in this frame), a neighbour saw the background: it is read
    there along that pixel's flow -- for a row read after the reference, in the
    previous frame, which the object had not yet covered; before it, in the next one;
    where that neighbour's sample lies outside its frame, in the other (a fast pan
    carries the background near the side out of the next frame; the previous one, the
    object further back then, shows it); with ``lone``, a lone neighbour (a pair, a
    clip's ends) for every row, where the object has moved on too.
    Across the row's motion a flat object's flow is unsure (the aperture): only the
    part along it counts. :func:`confirmed` then checks each pixel on the picture.

    Parameters
    ----------
    maps : tuple of ndarray of shape (h, w)
        Backward maps on the flows' grid (sources in its pixels).
    field : ndarray of shape (h, w, 2)
        The forward displacement ``p = s - field(s)`` the maps invert, in grid pixels.
    flows : list of ndarray of shape (h, w, 2)
        Flow from this frame to each neighbour.
    offsets : list of int
        Each flow's neighbour (-1: the previous frame, 1: the next).
    reference_row : float
        The reference scanline (pixels of the grid, top-bottom).
    lone : bool
        Whether the frame shows an object moving on its own: a lone neighbour is then
        read for every row (without one, a fast pan's flow errors would be taken for
        it), and of two, the other's view is returned for :func:`confirmed`.
    here : bool
        Also the pixels whose maps did not settle though the background's source in
        this frame moves as the background (the maps' fixed point went to the object
        beside it): read in this frame there, as flow index ``len(flows)``.

    Returns
    -------
    (ys, xs, k, delta, qy, qx, k2, delta2) or None
        The pixels, the index of the flow whose neighbour to read, where to read it less
        the pixel (grid pixels), the pixel whose displacement it took, and where the
        other neighbour would be read (``k2`` -1 where there is none, its sample leaves
        its frame, or without ``lone``; for :func:`confirmed`); None where nothing is
        uncovered.
    """
    mx, my = maps
    h, w = mx.shape
    if field.shape[:2] != (h, w) or any(f.shape[:2] != (h, w) for f in flows):
        return None  # not on one grid: not followed
    gx, gy = pixel_grid(h, w)

    def unsettled(mx: np.ndarray, my: np.ndarray, gx: np.ndarray, gy: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return the maps' displacement, their sources' own and where the two agree."""
        disp = cv2.merge([mx - gx, my - gy])
        own = cv2.remap(field, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        # (OpenCV's per-channel range test: NumPy's reductions over an axis of two are slow)
        return disp, own, cv2.inRange(cv2.subtract(own, disp), (-SETTLED, -SETTLED),
                                      (SETTLED, SETTLED))

    # Every other pixel of every other row first: most frames have nothing uncovered, and
    # what is comes in groups (GROUP) wider than that.
    half = [np.ascontiguousarray(a[::2, ::2]) for a in (mx, my, gx, gy)]
    if cv2.countNonZero(unsettled(*half)[2]) == half[0].size:
        return None
    disp, own, settles = unsettled(mx, my, gx, gy)
    within = cv2.bitwise_and(cv2.inRange(mx, 0, w - 1), cv2.inRange(my, 0, h - 1))
    suspects = cv2.bitwise_and(within, cv2.bitwise_not(settles))
    if not cv2.countNonZero(suspects):
        return None
    ys, xs = np.nonzero(suspects)
    settled, inside = settles > 0, within > 0
    # The background's displacement: the median of the row (a near object is narrow).
    # Parallax is along it; across it a flat object's flow is unsure (the aperture).
    rows, at = np.unique(ys, return_inverse=True)
    each = disp[rows, ::2]
    middle = np.median(each, axis=1)
    spread = np.median(np.hypot(*(each - middle[:, None]).transpose(2, 0, 1)), axis=1)
    around, size = middle[at], np.hypot(*middle.T)[at]
    along = around / np.maximum(size, 1e-6)[:, None]
    keep = ((size >= SETTLED) & (spread[at] <= UNIFORM * size)
            & (np.abs(((own - disp)[ys, xs] * along).sum(axis=1)) > SETTLED))
    ys, xs, around, along = ys[keep], xs[keep], around[keep], along[keep]
    # Candidates along eight directions, (n, c): the nearest to the background's motion.
    step = (_DIRECTIONS[None, :, None, :] * _STEPS[None, None, :, None]).reshape(1, -1, 2)
    qy, qx = ys[:, None] + step[..., 0], xs[:, None] + step[..., 1]
    usable = (qy >= 0) & (qy < h) & (qx >= 0) & (qx < w)
    qy, qx = qy.clip(0, h - 1), qx.clip(0, w - 1)
    usable &= inside[qy, qx] & settled[qy, qx]
    score = np.abs(disp[qy, qx] - around[:, None]).sum(axis=-1) + 0.02 * np.hypot(*step[0].T)
    score[~usable] = np.inf
    best = score.argmin(axis=1)
    some = np.flatnonzero(np.isfinite(score[np.arange(best.size), best]))  # a donor found
    qy, qx = qy[some, best[some]], qx[some, best[some]]
    ys, xs, d, along = ys[some], xs[some], disp[qy, qx], along[some]
    # Uncovered where the background's source in this frame moves otherwise.
    there = sample_points(field, xs + d[:, 0], ys + d[:, 1])
    hidden = np.abs(((there - d) * along).sum(axis=1)) > SETTLED
    mine_here = None
    if here:
        seen = ~hidden & _inside(xs + d[:, 0], ys + d[:, 1], (h, w))
        mine_here = tuple(a[seen] for a in (ys, xs, d, qy, qx))
    ys, xs, d, qy, qx = ys[hidden], xs[hidden], d[hidden], qy[hidden], qx[hidden]
    late = ys + d[:, 1] >= reference_row  # its row, read after the reference
    k = np.full(ys.size, -1)
    delta = np.zeros((ys.size, 2), np.float32)
    for rank in (0, 1):
        for i, offset in enumerate(offsets):
            # A lone neighbour (a pair, a clip's ends) is the only one to read: the object
            # has moved on there too (confirmed() checks it on the picture). Of two, each
            # pixel's preferred one first, then the other.
            if len(offsets) == 1 and rank == 1:
                continue
            if lone and len(offsets) == 1:
                mine = np.arange(ys.size)
            else:
                mine = np.flatnonzero((late if offset < 0 else ~late) ^ (rank == 1))
                mine = mine[k[mine] < 0]
            if not mine.size:
                continue
            ok, n = _read(flows[i], maps, ys[mine], xs[mine], qy[mine], qx[mine], d[mine])
            k[mine[ok]] = i
            delta[mine[ok]] = n[ok]
    found = k >= 0
    if mine_here is not None and mine_here[0].size:  # read in this frame (index len(flows))
        hy, hx, hd, hqy, hqx = mine_here
        ys, xs, qy, qx = (np.concatenate([a[found], b]) for a, b in
                          ((ys, hy), (xs, hx), (qy, hqy), (qx, hqx)))
        k = np.concatenate([k[found], np.full(hy.size, len(flows))])
        delta = np.concatenate([delta[found], hd.astype(np.float32)])
        d = np.concatenate([d[found], hd])
    elif not found.any():
        return None
    else:
        ys, xs, k, delta, qy, qx = (a[found] for a in (ys, xs, k, delta, qy, qx))
        d = d[found]
    # Where the other neighbour would see it too (confirmed(): two views that agree), in
    # a frame with an object moving on its own (``lone``; without one, a near object
    # the flow follows -- a finger passing the lens -- can show in both).
    k2 = np.full(ys.size, -1)
    delta2 = np.zeros((ys.size, 2), np.float32)
    if lone and len(offsets) == 2:
        for i in (0, 1):
            mine = np.flatnonzero(k == 1 - i)
            if not mine.size:
                continue
            ok, n = _read(flows[i], maps, ys[mine], xs[mine], qy[mine], qx[mine], d[mine])
            k2[mine[ok]] = i
            delta2[mine[ok]] = n[ok]
    return ys, xs, k, delta, qy, qx, k2, delta2


def _inside(x: np.ndarray, y: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Which points ``(x, y)`` (pixels of a grid of ``shape``) lie inside it."""
    h, w = shape
    return (x >= -0.5) & (x <= w - 0.5) & (y >= -0.5) & (y <= h - 0.5)


def _read(flow: np.ndarray, maps: tuple[np.ndarray, np.ndarray], ys: np.ndarray,
          xs: np.ndarray, qy: np.ndarray, qx: np.ndarray, d: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray]:
    """Where ``flow``'s neighbour shows the pixels ``(ys, xs)``, and whether it is inside.

    The read, less the pixel: their donors' (``(qy, qx)``) displacement ``d`` plus the
    flow at the donors' sources (``maps``).
    """
    n = d + sample_points(flow, maps[0][qy, qx], maps[1][qy, qx])
    return _inside(xs + n[:, 0], ys + n[:, 1], maps[0].shape), n


def uncovered_sources(found: tuple[np.ndarray, ...], grid: tuple[int, int],
                      plane: tuple[int, int]) -> list:
    """Parts (as :func:`neighbour_sources`) of a plane for the pixels :func:`uncovered` found.

    Each pixel of the maps' ``grid`` stands for the plane's pixels nearest it, all read
    from its neighbour with its displacement (scaled to the plane).
    """
    ys, xs, k, delta = found[:4]
    (h, w), (ph, pw) = grid, plane
    sx, sy = pw / w, ph / h
    # The plane's pixels whose nearest grid pixel is (y, x): a block of at most by x bx.
    by, bx = int(np.ceil(sy)) + 1, int(np.ceil(sx)) + 1
    oy, ox = np.mgrid[0:by, 0:bx]
    py = np.floor(ys * sy - 0.5).astype(int)[:, None] + oy.ravel()
    px = np.floor(xs * sx - 0.5).astype(int)[:, None] + ox.ravel()
    near_y = np.floor((py + 0.5) / sy).astype(int)
    near_x = np.floor((px + 0.5) / sx).astype(int)
    mine = ((near_y == ys[:, None]) & (near_x == xs[:, None]) & (py >= 0) & (py < ph)
            & (px >= 0) & (px < pw))
    idx = np.broadcast_to(np.arange(ys.size)[:, None], mine.shape)[mine]
    py, px = py[mine], px[mine]
    nx = px + delta[idx, 0] * sx
    ny = py + delta[idx, 1] * sy
    parts = []
    for i in np.unique(k):
        sel = k[idx] == i
        parts.append((int(i), py[sel], px[sel], nx[sel], ny[sel]))
    return parts


def confirmed(found: tuple, grid: tuple[int, int], out: np.ndarray, planes: list[np.ndarray],
              shown: np.ndarray | None = None) -> tuple | None:
    """Keep the uncovered pixels whose neighbour's sample looks like their background.

    Checked on a plane at each pixel's centre: the neighbour's sample must be nearer in
    value to the background beside it (the output at the pixel whose displacement it
    took and the next two on from it, away from the pixel) than the output there is now
    (the near object stretched over it) -- or, where the other neighbour sees the pixel
    too, agree with what that one shows (within :data:`AGREE` grey levels: two views of
    one background; the pixels beside may be the object itself, where its own field
    was the background's). Where the pixel whose displacement it took lies on a fitted
    object (``shown``, bool on the grid: a near pole whose motion there is close to the
    background's), the pixels as far on the other side stand for the background instead,
    unless an object is shown there too. A wrong displacement (a field that does not
    settle where no object is) would otherwise bring in whatever the neighbour shows
    there. What is left must come in groups of at least :data:`GROUP` pixels of the
    grid: an object's edge is uncovered along its length, and single pixels drawn from
    elsewhere show as specks.
    """
    ys, xs, k, delta, qy, qx = found[:6]
    (h, w), (ph, pw) = grid, out.shape[:2]
    sx, sy = pw / w, ph / h

    def at(gy: np.ndarray, gx: np.ndarray) -> np.ndarray:
        py = np.clip(np.rint((gy + 0.5) * sy - 0.5), 0, ph - 1).astype(int)
        px = np.clip(np.rint((gx + 0.5) * sx - 0.5), 0, pw - 1).astype(int)
        return out[py, px].astype(np.float32).reshape(gy.size, -1)

    def line(gy: np.ndarray, gx: np.ndarray, dy: np.ndarray, dx: np.ndarray,
             bounded: bool = False) -> np.ndarray:
        """Return the output's mean at three grid pixels on from ``(gy, gx)`` by ``(dy, dx)``.

        ``bounded``: each held to the grid first (else only the plane's pixel is).
        """
        steps = [(gy + j * dy, gx + j * dx) for j in range(3)]
        if bounded:
            steps = [(np.clip(y, 0, h - 1), np.clip(x, 0, w - 1)) for y, x in steps]
        (y0, x0), (y1, x1), (y2, x2) = steps
        return (at(y0, x0) + at(y1, x1) + at(y2, x2)) / 3.0

    def nearer(ref: np.ndarray) -> np.ndarray:
        """Return where the neighbour's sample is nearer ``ref`` in colour than the output."""
        return np.abs(seen - ref).sum(axis=1) < np.abs(now - ref).sum(axis=1)

    now = at(ys, xs)
    uy, ux = np.sign(qy - ys), np.sign(qx - xs)  # on from the donor, away from the pixel
    back = line(qy, qx, uy, ux)
    seen = np.empty_like(now)
    for i in np.unique(k):
        sel = k == i
        px = np.clip(np.rint((xs[sel] + 0.5) * sx - 0.5), 0, pw - 1)
        py = np.clip(np.rint((ys[sel] + 0.5) * sy - 0.5), 0, ph - 1)
        seen[sel] = sample_points(planes[i], px + delta[sel, 0] * sx, py + delta[sel, 1] * sy
                            ).astype(np.float32).reshape(sel.sum(), -1)
    keep = nearer(back)
    if shown is not None:
        # A donor on a fitted object (a pole whose motion is near the background's) is
        # no background: there the pixels as far on the other side are, if no object.
        oy, ox = 2 * ys - qy, 2 * xs - qx
        valid = (oy >= 0) & (oy < h) & (ox >= 0) & (ox < w)
        oy, ox = oy.clip(0, h - 1), ox.clip(0, w - 1)
        other = valid & shown[qy, qx] & ~shown[oy, ox]
        if other.any():
            keep |= other & nearer(line(oy, ox, -uy, -ux, bounded=True))
    if len(found) > 6:
        k2, delta2 = found[6:8]
        for i in np.unique(k2[k2 >= 0]):
            sel = np.flatnonzero(k2 == i)
            px = np.clip(np.rint((xs[sel] + 0.5) * sx - 0.5), 0, pw - 1)
            py = np.clip(np.rint((ys[sel] + 0.5) * sy - 0.5), 0, ph - 1)
            other = sample_points(planes[i], px + delta2[sel, 0] * sx, py + delta2[sel, 1] * sy
                                  ).astype(np.float32).reshape(sel.size, -1)
            keep[sel] |= np.abs(other - seen[sel]).max(axis=1) <= AGREE
    mask = np.zeros(grid, np.uint8)
    mask[ys[keep], xs[keep]] = 1
    _, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    keep &= stats[labels[ys, xs], cv2.CC_STAT_AREA] >= GROUP
    if not keep.any():
        return None
    return tuple(a[keep] for a in found)
