"""Flows scored over patches, and sharpened at motion boundaries.

The photometric cost of a flow (or any map) over square patches -- what picks between
two flows, between the flow and the global motion (also where content enters the frame,
:func:`unmatched_entering`), and between the flows of the two sides of a motion
boundary, which DIS smooths across (:func:`refine_motion_edges`). Sign as in
:mod:`unjello.motion.flow.dis`.
"""

from __future__ import annotations

import cv2
import numpy as np

from ...timing import pixel_grid

__all__ = ["patch_cost", "map_cost", "costlier", "unmatched_entering", "refine_motion_edges",
           "ENTER_COST", "ENTER_FLAT", "ENTER_AGREE"]

#: Where content enters the frame (:func:`unmatched_entering`), a flow is kept only if its
#: patch cost is at most this many times the median cost of the rest of the frame's ...
ENTER_COST = 10.0
#: ... and only on 2-D texture: a patch's mean smaller eigenvalue of the structure tensor at
#: least this share of the frame's 90th percentile (``docs/tuning.md#enter_flat``).
ENTER_FLAT = 0.02
#: ... and only where the flow outside the band moves as the translation does (its median within
#: this share of it, 2 px at least). (``docs/tuning.md#enter_agree``)
ENTER_AGREE = 0.1


def patch_cost(cur: np.ndarray, other: np.ndarray, gx: np.ndarray, gy: np.ndarray,
                flow: np.ndarray, window: int) -> np.ndarray:
    """Mean absolute difference of ``cur`` and ``other`` moved by ``flow``, over square patches.

    ``gx, gy`` are the pixel coordinates of ``cur`` in ``other`` without motion (a crop's
    offset included).
    """
    return map_cost(cur, other, gx + flow[..., 0], gy + flow[..., 1], window)


def map_cost(cur: np.ndarray, other: np.ndarray, map_x: np.ndarray, map_y: np.ndarray,
             window: int) -> np.ndarray:
    """Mean absolute difference of ``cur`` and ``other`` at ``(map_x, map_y)``, over patches."""
    warped = cv2.remap(other, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    return cv2.boxFilter(cv2.absdiff(warped, cur), -1, (window, window))


def costlier(cur: np.ndarray, other: np.ndarray, maps: tuple[np.ndarray, np.ndarray],
              than: tuple[np.ndarray, np.ndarray], window: int, margin: float = 0.0
              ) -> np.ndarray:
    """Where ``maps`` cost more than ``than`` (:func:`map_cost`), by over ``margin``: a mask.

    255 where they do. The patch means are linear, so the two costs are compared as one
    patch mean of their difference: one box filter instead of two.
    """
    def miss(at: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
        return cv2.absdiff(cv2.remap(other, *at, cv2.INTER_LINEAR,
                                     borderMode=cv2.BORDER_REPLICATE), cur)

    gap = cv2.boxFilter(cv2.subtract(miss(maps), miss(than)), -1, (window, window))
    return (gap > margin).view(np.uint8) * np.uint8(255)


def unmatched_entering(cur: np.ndarray, other: np.ndarray, flow: np.ndarray,
                       shift: np.ndarray, window: int) -> np.ndarray:
    """Where content enters the frame, the flows that nothing confirms: a mask.

    Where the frame's translation ``shift`` carries a pixel of ``cur`` outside ``other``,
    ``other`` did not see it, unless it moves on its own (a near pole, a car). A flow
    landing inside there is kept only where it matches ``other`` well over a patch (at
    most :data:`ENTER_COST` times the median patch cost elsewhere, 2 grey levels at
    least) on two-dimensional texture (:data:`ENTER_FLAT`), where the flow elsewhere
    confirms the translation (:data:`ENTER_AGREE`): in a fast diagonal pan DIS
    carried the rows entering at the top onto whatever looked alike in ``other`` (a
    flat wall at -6 px where the frame moved -70), and its own inverse passed them as
    consistent (``docs/history/measurements.md``).

    Parameters
    ----------
    cur, other : ndarray of shape (h, w), uint8 or float32
        The frame and the one the flow points to (grey).
    flow : ndarray of shape (h, w, 2)
        Flow from ``cur`` to ``other`` (``cur(s) ~ other(s + flow(s))``).
    shift : ndarray of shape (2,)
        The frame's translation, as ``flow``.
    window : int
        Side of the patches (px).

    Returns
    -------
    ndarray of bool, shape (h, w)
        The pixels of the band whose flow nothing confirms (the caller gives them
        ``shift``: they then land outside, as entering content does).
    """
    h, w = cur.shape[:2]
    gx, gy = pixel_grid(h, w)
    sx, sy = gx + np.float32(shift[0]), gy + np.float32(shift[1])
    band = (sx < 0) | (sx > w - 1) | (sy < 0) | (sy > h - 1)
    sub = (slice(None, None, 4), slice(None, None, 4))  # medians of every 16th pixel
    rest = flow[sub][~band[sub]]
    if not rest.size or np.hypot(*(np.median(rest, axis=0) - shift)) > max(
            2.0, ENTER_AGREE * float(np.hypot(*shift))):
        return np.zeros((h, w), bool)  # no band, or a translation the flow does not share
    cf, of = np.asarray(cur, np.float32), np.asarray(other, np.float32)
    cost = patch_cost(cf, of, gx, gy, np.asarray(flow, np.float32), window)
    level = max(2.0, ENTER_COST * float(np.median(cost[sub][~band[sub]])))
    texture = cv2.boxFilter(cv2.cornerMinEigenVal(cf, 5), -1, (window, window))
    flat = texture < ENTER_FLAT * float(np.percentile(texture[sub], 90))
    return band & ((cost > level) | flat)


#: A motion boundary: the flow varies by more than this (px) within 9 x 9 pixels.
EDGE_SPREAD = 2.0


#: Side (px) of the patch a flow borrowed across a motion boundary is scored over.
EDGE_WINDOW = 5


def refine_motion_edges(cur: np.ndarray, prev: np.ndarray, flow: np.ndarray,
                        spread: float = EDGE_SPREAD, radii: tuple[int, ...] = (3, 8),
                        window: int = EDGE_WINDOW) -> np.ndarray:
    """Give pixels near a motion boundary the flow of the side they belong to.

    DIS smooths the flow across the edge of a nearer layer or a moving object, so the
    pixels of the background next to it move partly with it (and the other way round).
    Where the flow varies by more than ``spread`` px within 9x9 pixels, each pixel may
    take the flow found ``radii`` px away in one of eight directions, if that flow
    matches the previous frame better over a ``window`` x ``window`` patch (sum of
    absolute differences of the warped previous frame). Cost: nothing where there are
    no boundaries (measurements: ``docs/tuning.md``).

    Parameters
    ----------
    cur, prev : ndarray of shape (h, w), float32
        The frame and the one the flow points to.
    flow : ndarray of shape (h, w, 2), float32
        Flow from ``cur`` to ``prev`` (``cur(s) ~ prev(s + flow(s))``).

    Returns
    -------
    ndarray of shape (h, w, 2), float32
    """
    kernel = np.ones((9, 9), np.uint8)
    edge = np.zeros(flow.shape[:2], dtype=bool)
    for k in range(2):
        f = flow[..., k]
        edge |= (cv2.dilate(f, kernel) - cv2.erode(f, kernel)) > spread
    if not edge.any():
        return flow
    # Work on the rows and columns around the boundaries only.
    pad = max(radii) + window
    ys, xs = np.nonzero(edge)
    h, w = flow.shape[:2]
    y0, y1 = max(0, ys.min() - pad), min(h, ys.max() + pad + 1)
    x0, x1 = max(0, xs.min() - pad), min(w, xs.max() + pad + 1)
    crop = (slice(y0, y1), slice(x0, x1))
    fl, here, near = flow[crop], cur[crop], edge[crop]
    ch, cw = near.shape
    gx, gy = pixel_grid(ch, cw, y0, x0)

    def cost(f: np.ndarray) -> np.ndarray:
        return patch_cost(here, prev, gx, gy, f, window)

    # Candidate 0 is the pixel's own flow; ties keep it.
    offsets = [(0, 0)] + [(dx * r, dy * r) for r in radii
                          for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1),
                                         (1, 1), (1, -1), (-1, 1), (-1, -1))]
    padded = cv2.copyMakeBorder(fl, pad, pad, pad, pad, cv2.BORDER_REPLICATE)
    best_cost = cost(fl)
    pick = np.zeros((ch, cw), np.int64)
    for i, (ox, oy) in enumerate(offsets[1:], start=1):  # one candidate held at a time
        c = cost(padded[pad + oy:pad + oy + ch, pad + ox:pad + ox + cw])
        better = near & (c < best_cost)
        np.copyto(best_cost, c, where=better)
        pick[better] = i
    off = np.array(offsets)[pick]  # (ch, cw, 2)
    src_y = np.clip(np.arange(ch)[:, None] + off[..., 1], 0, ch - 1)
    src_x = np.clip(np.arange(cw)[None, :] + off[..., 0], 0, cw - 1)
    best = fl[src_y, src_x]
    out = flow.copy()
    out[crop] = best
    return out
