"""What a frame does not see beyond its edge, taken from its neighbours.

During fast motion the reference time shows content that the frame's own scanlines never
saw (its edges): the backward maps point outside the frame there. A neighbouring frame
often saw it; the frame's flow to that neighbour (extended past the edge) says where
(:func:`neighbour_sources`), and :func:`fill_from_neighbours` samples it there, instead of
repeating the edge. Background a nearer object uncovered is
:mod:`unjello.warp.fill.uncovered`'s, nearer objects leaving the frame
:mod:`unjello.warp.fill.leaving`'s; :class:`unjello.warp.fill.planes.NeighbourFill` puts
them together for :class:`unjello.warp.warper.PictureWarper`.
"""

from __future__ import annotations

import cv2
import numpy as np

from ..bands import PlaneMaps

__all__ = ["neighbour_sources", "fill_from_neighbours", "unseen_share", "outside_share",
           "sample_points", "edge_slopes", "beyond_rows", "INSET"]

#: Pixels of the flow's grid between the frame's border and where the flow carried past
#: it is read (:func:`neighbour_sources`).
INSET = 3.0


def sample_points(image: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Bilinear samples of ``image`` at the points ``(x, y)`` (1-D arrays)."""
    n = x.size
    cols = 1024
    rows = max(1, -(-n // cols))
    mx = np.zeros(rows * cols, np.float32)
    my = np.zeros(rows * cols, np.float32)
    mx[:n], my[:n] = x, y
    out = cv2.remap(image, mx.reshape(rows, cols), my.reshape(rows, cols), cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_REPLICATE)
    return out.reshape(rows * cols, *image.shape[2:])[:n]


def neighbour_sources(maps: tuple[np.ndarray, np.ndarray] | PlaneMaps, flows: list[np.ndarray],
                      offsets: list[int] | None = None, reference_row: float | None = None,
                      slope: tuple[np.ndarray, np.ndarray] | None = None
                      ) -> list[tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """Where to take the output pixels whose source lies outside the frame.

    During fast motion the reference time shows scene content that the frame's own
    scanlines never saw (its edges). A neighbouring frame often did: the source point
    ``s`` (outside the frame) is followed there by the frame's flow, extended past the
    edge as the flow of the nearest pixel, and sampled where it lands inside.

    Parameters
    ----------
    maps : tuple of ndarray of shape (h, w), or PlaneMaps
        The plane's backward maps (plane pixels), whole or as the coarse maps they are
        interpolated from (:class:`~unjello.warp.bands.PlaneMaps`): then only pixels near
        a coarse sample that leaves the frame can leave it, and only those are tested.
    flows : list of ndarray
        Flow from this frame to each neighbour, (hf, wf, 2) in pixels of that (hf, wf)
        grid; a pixel goes to the first neighbour that saw it.
    offsets, reference_row : list of int, float, optional
        Each flow's neighbour (-1: the previous frame, 1: the next) and the reference
        scanline (plane pixels, top-bottom). What the reference instant shows beyond the
        edge of a row read after it, the previous frame saw; of one read before it, the
        next (the frame's own flow to the other may land inside on what entered the
        frame, matched to nothing): each pixel tries that neighbour first. Without them,
        the flows in their order.
    slope : tuple of ndarray, optional
        How the camera's displacement changes a row at the top and at the bottom
        (:func:`edge_slopes`, plane pixels): a source beyond those rows is moved on by it
        (:func:`beyond_rows`) before it is followed.

    Returns
    -------
    list of (k, ys, xs, nx, ny)
        Output pixels ``(ys, xs)`` to take from neighbour ``k`` at ``(nx, ny)``; ``k``
        -1 (the last part, when any): the pixels no neighbour saw either, at their
        sources beyond the edge (:func:`fill_from_neighbours` leaves them as they are).
    """
    h, w = maps.shape if isinstance(maps, PlaneMaps) else maps[0].shape
    test = maps.coarse if isinstance(maps, PlaneMaps) else maps
    th, tw = test[0].shape
    # A coarse sample's pixels reach up to half a sample beyond it (the displacement is
    # held to the frame's edge): only samples at least half a sample inside are surely
    # inside.
    lo, hi = (0.0, 1.0) if isinstance(maps, PlaneMaps) else (-0.5, 0.5)
    inside = cv2.bitwise_and(cv2.inRange(test[0], lo, tw - hi),
                             cv2.inRange(test[1], lo, th - hi))
    if cv2.countNonZero(inside) == th * tw:
        return []
    outside = cv2.bitwise_not(inside)
    if isinstance(maps, PlaneMaps):  # bilinear upsampling stays inside its 2x2 coarse samples
        xs, ys, sx, sy = maps.outside(cv2.dilate(outside, np.ones((3, 3), np.uint8)))
    else:
        pts = cv2.findNonZero(outside).reshape(-1, 2)
        xs, ys = pts[:, 0], pts[:, 1]
        sx, sy = maps[0][ys, xs], maps[1][ys, xs]
    if slope is not None:
        sx, sy = beyond_rows(sx, sy, h, slope)
    order = list(range(len(flows)))
    if offsets is not None and reference_row is not None and len(flows) > 1:
        late = sy >= reference_row  # read after the reference: the previous frame first
        parts = []
        for first, later in ((late, 1), (~late, -1)):  # the neighbour tried last
            take = sorted(order, key=lambda k: offsets[k] == later)
            parts += _follow([flows[k] for k in take], take, ys[first], xs[first],
                             sx[first], sy[first], h, w)
        return parts
    return _follow(flows, order, ys, xs, sx, sy, h, w)


def edge_slopes(displacement: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """How a per-row ``displacement`` (h, 2) changes a row at the top and at the bottom.

    Each over the eighth of the rows nearest that edge: ``(top, bottom)``, each ``(dx, dy)``
    per row.

    >>> d = np.stack([np.zeros(8), 0.5 * np.arange(8)], axis=1)
    >>> [s.tolist() for s in edge_slopes(d)]
    [[0.0, 0.5], [0.0, 0.5]]
    """
    h = len(displacement)
    m = max(1, h // 8)
    if h <= m:
        return np.zeros(2), np.zeros(2)
    d = np.asarray(displacement, np.float64)
    return (d[m] - d[0]) / m, (d[h - 1] - d[h - 1 - m]) / m


def beyond_rows(sx: np.ndarray, sy: np.ndarray, h: int,
                slope: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Move sources beyond the first or last row on as the camera's motion goes on there.

    The backward maps hold the displacement beyond the frame at its edge row's (eq. 26's
    per-scanline displacement, sampled at the border). But each row is read later than
    the one above it: beyond the last row the displacement goes on changing by the
    bottom ``slope`` a row (before the first, by the top one), and in a tilt or a
    diagonal pan the source of a pixel beyond the frame lies further out than the edge
    row's displacement puts it. A source ``s0`` found with that displacement moves to the
    fixed point of ``s = s0 + slope (s_y - edge)``, ``edge`` the first or last row
    (none where the slope reaches 0.9 px a row: the scan barely outruns the motion).

    >>> x, y = beyond_rows(np.array([5.0]), np.array([12.0]), 10, (np.zeros(2),
    ...                    np.array([1.0, 0.5])))
    >>> float(x[0]), float(y[0])
    (11.0, 15.0)
    """
    sx, sy = np.array(sx, np.float64), np.array(sy, np.float64)
    for edge, g, sel in ((0.0, slope[0], sy < 0.0), (h - 1.0, slope[1], sy > h - 1.0)):
        if not sel.any() or g[1] >= 0.9:
            continue
        k = (sy[sel] - edge) / (1.0 - g[1])
        sx[sel] += g[0] * k
        sy[sel] = edge + k
    return sx.astype(np.float32), sy.astype(np.float32)


def _follow(flows: list[np.ndarray], which: list[int], ys: np.ndarray, xs: np.ndarray,
            sx: np.ndarray, sy: np.ndarray, h: int, w: int) -> list:
    """Follow the points ``(sx, sy)`` into each flow's neighbour in turn (see above)."""
    parts = []
    for k, flow in zip(which, flows, strict=True):
        if not ys.size:
            break
        hf, wf = flow.shape[:2]
        # Past the edge, the flow a few pixels in: the border's own is DIS's least sure.
        f = sample_points(flow, np.clip((sx + 0.5) * (wf / w) - 0.5, INSET, wf - 1 - INSET),
                    np.clip((sy + 0.5) * (hf / h) - 0.5, INSET, hf - 1 - INSET))
        nx = sx + f[:, 0] * (w / wf)
        ny = sy + f[:, 1] * (h / hf)
        ok = (nx >= -0.5) & (nx <= w - 0.5) & (ny >= -0.5) & (ny <= h - 0.5)
        parts.append((k, ys[ok], xs[ok], nx[ok], ny[ok]))
        ys, xs, sx, sy = ys[~ok], xs[~ok], sx[~ok], sy[~ok]
    if ys.size:
        parts.append((-1, ys, xs, sx, sy))
    return parts


def fill_from_neighbours(out: np.ndarray, parts: list, planes: list[np.ndarray]
                         ) -> np.ndarray:
    """Fill ``out`` in place from neighbouring planes, as :func:`neighbour_sources` found.

    Parameters
    ----------
    out : ndarray of shape (h, w[, c])
        The warped plane.
    parts : list
        :func:`neighbour_sources` of its maps.
    planes : list of ndarray
        The neighbours' planes of the same size (top-bottom), in the order of the flows.

    Returns
    -------
    ndarray
        ``out``.
    """
    for k, ys, xs, nx, ny in parts:
        if ys.size and k >= 0:
            out[ys, xs] = sample_points(planes[k], nx, ny)
    return out


#: The share of a frame its maps take from outside is counted on every this-many-th
#: pixel of every this-many-th row.
OUTSIDE_STEP = 8


def outside_share(maps: tuple[np.ndarray, np.ndarray] | PlaneMaps,
                  step: int = OUTSIDE_STEP) -> float:
    """Share of the pixels of backward ``maps`` whose source lies beyond the frame's edge.

    Counted on every ``step``-th pixel of every ``step``-th row (a 1080p frame's maps
    whole: 10 ms). ``maps`` whole, or as :class:`~unjello.warp.bands.PlaneMaps`.
    """
    if isinstance(maps, PlaneMaps):
        h, w = maps.shape
        mx, my = maps.sample(step)
    else:
        h, w = maps[0].shape
        mx, my = (np.ascontiguousarray(m[step // 2::step, step // 2::step]) for m in maps)
    inside = cv2.bitwise_and(cv2.inRange(mx, -0.5, w - 0.5), cv2.inRange(my, -0.5, h - 0.5))
    return 1.0 - cv2.countNonZero(inside) / float(mx.size)


def unseen_share(parts: list, shape: tuple[int, int]) -> float:
    """Return the share of a plane of ``shape`` that no frame saw, from its ``parts``."""
    return sum(p[1].size for p in parts if p[0] < 0) / float(shape[0] * shape[1])
