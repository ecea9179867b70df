"""Nearer objects leaving the frame at a side, carried beyond its edge by their own motion.

A pole a pan passes leaves the frame at a side: the rows read after it left never saw it,
and the strip beyond the edge, taken from a neighbour along the background's motion
(:func:`unjello.warp.fill.neighbours.neighbour_sources`), ends it there. :func:`edge_objects` finds
such objects in the per-pixel field where they touch a side, :func:`settled_objects`
keeps those a neighbour shows where their velocity carries them, and
:func:`objects_beyond` takes the pixels they cover beyond the edge from that neighbour.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import cv2
import numpy as np

from .neighbours import INSET, sample_points
from .uncovered import UNIFORM

__all__ = ["EdgeObject", "edge_objects", "settled_objects", "objects_beyond",
           "NEAR_REFERENCE", "FASTER", "RUN", "BAND", "SEARCH", "HELD", "ALIKE", "MISSED",
           "CORE", "BESIDE"]

#: Rows of the field within this share of the readout of the reference scanline do not
#: measure an object's velocity (its displacement there is near zero whatever it is).
NEAR_REFERENCE = 0.07
#: An object at the side moves faster than its row's background by this share of the
#: background's speed at least (and by 2 px of the grid a frame): nearer, in a pan.
FASTER = 0.1
#: Fewest rows (of the grid) an object touches the side over, gaps of two rows bridged.
RUN = 8
#: Columns (of the grid) from the side in which an object's velocity is measured.
BAND = 8
#: Farthest (grid pixels a frame interval, along x) an object's velocity is moved to match
#: what its neighbours show (:func:`settled_objects`).
SEARCH = 12.0
#: Least share of an object's core pixels a neighbour must show where they are carried.
HELD = 0.6
#: Largest grey-level difference between an object's visible pixel and what a neighbour
#: shows where the object's own motion carries a pixel beyond the edge.
ALIKE = 10.0
#: Grid pixels along x either side of where an object's motion carries a pixel, all to be
#: unlike the object for a neighbour's look of it there to be refused (:func:`objects_beyond`).
MISSED = 2.0
#: An object's core is its band's fastest quarter; where that is all background, the pixels
#: as fast as it less this share of its lead on the background too (:func:`settled_objects`).
CORE = 0.25
#: Farthest (grid columns inward of the band) the background beside an object is looked
#: for (:func:`settled_objects`: a core pixel like it is no part of the object).
BESIDE = 24
#: :func:`objects_beyond`'s mark of a pixel re-read along the background's motion.
_REREAD = 99


@dataclass(frozen=True)
class EdgeObject:
    """A nearer object touching a side of the frame, moving as one (:func:`edge_objects`).

    ``side``: -1 the left, 1 the right; ``rows`` and ``cols``: the grid pixels near the
    side whose field is its core (rows ascending); ``velocity``: its image velocity (grid
    pixels a frame interval, x and y); ``behind``: its background's; ``beside``: per core
    pixel, the nearest column inward whose field is the background's (-1: none near);
    ``wider``: rows, columns and ``beside`` of the band's pixels a little slower than the
    core (:data:`CORE`), where it turns out to be background (:func:`settled_objects`).
    """

    side: int
    rows: np.ndarray
    cols: np.ndarray
    velocity: tuple[float, float]
    behind: tuple[float, float]
    beside: np.ndarray | None = None
    wider: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None


def edge_objects(field: np.ndarray, readout: float, reference_row: float
                 ) -> list[EdgeObject]:
    """Nearer objects touching the frame's left and right sides, from the per-pixel field.

    A pole a pan passes leaves the frame at a side: in the rows read after it left, the
    frame never saw it, and the strip beyond the edge is taken from a neighbour along the
    background's motion -- the pole ends there. Where it touches the side its field is
    its own (a rigid fit where the flow could not follow it): ``D(y) = v tau(y)`` with
    ``tau`` the time from the reference to row ``y`` (eq. 26 for a constant velocity
    ``v``). Runs of rows (:data:`RUN`) whose field a few pixels in (:data:`INSET`) gives
    a velocity :data:`FASTER` than the row's background (its median) along the
    background's motion are such objects, with the median velocity of the run's core. Rows
    near the reference (:data:`NEAR_REFERENCE`) measure nothing, and rows that do not
    move as one (:data:`UNIFORM`) are left alone.

    Parameters
    ----------
    field : ndarray of shape (h, w, 2)
        Forward displacement ``p = s - field(s)`` in grid pixels.
    readout : float
        Share of the frame interval the scan takes.
    reference_row : float
        The reference scanline (grid rows, top-bottom).
    """
    h, w = field.shape[:2]
    tau = (np.arange(h) - reference_row) * (readout / h)
    far = np.flatnonzero(np.abs(tau) >= NEAR_REFERENCE * readout)
    if far.size < RUN or w <= 2 * INSET + 2:
        return []
    sides = ((-1, int(INSET)), (1, w - 1 - int(INSET)))
    edges = [field[far, col] / tau[far, None] for _, col in sides]
    # Most frames have nothing faster than the background at either side: a look with
    # each row's mean first (a narrow object moves it little), its median where needed.
    mean = cv2.resize(np.ascontiguousarray(field, np.float32), (1, h),
                      interpolation=cv2.INTER_AREA).reshape(h, 2)[far] / tau[far, None]
    rough = np.hypot(*mean.T)
    if all(np.count_nonzero((e * mean).sum(axis=1) / np.maximum(rough, 1e-6) - rough
                            > np.maximum(FASTER * rough, 2.0) / 2) < RUN for e in edges):
        return []
    every = field[far, ::8]  # a row's background: every 8th pixel is plenty
    back = np.median(every, axis=1) / tau[far, None]
    speed = np.hypot(*back.T)
    least = np.maximum(FASTER * speed, 2.0)
    whole = np.median(back, axis=0)
    out = []
    for (side, col), edge in zip(sides, edges, strict=True):
        rows = np.flatnonzero((edge * back).sum(axis=1) / np.maximum(speed, 1e-6) - speed
                              > least)
        if rows.size < RUN:
            continue
        # Rows that move as one (:data:`UNIFORM`): where the background moves unevenly
        # (forward motion, depth), faster is no sign of an object.
        spread = np.median(np.hypot(*(every[rows] / tau[far[rows], None, None]
                                      - back[rows, None]).transpose(2, 0, 1)), axis=1)
        rows = rows[spread <= UNIFORM * speed[rows]]
        band = slice(col, col + BAND) if side < 0 else slice(col - BAND + 1, col + 1)
        for run in np.split(rows, np.flatnonzero(np.diff(rows) > 3) + 1):
            if run.size < RUN:
                continue
            lo, hi = run[0], run[-1] + 1
            vel = field[far[lo:hi], band] / tau[far[lo:hi], None, None]
            faster = ((vel * back[lo:hi, None]).sum(axis=2)
                      / np.maximum(speed[lo:hi], 1e-6)[:, None]
                      - speed[lo:hi, None] > least[lo:hi, None])
            # Its field blends into the background's at its outline: the core's.
            ry, rx = np.nonzero(faster)
            mine = vel[ry, rx]
            base = back[lo:hi].mean(axis=0)
            fast = (mine * base).sum(axis=1)
            top = np.percentile(fast, 75)
            core = fast >= top
            near = ~core & (fast >= top - CORE * (top - float(base @ base)))
            v = np.median(mine[core], axis=0)
            b = np.median(back[lo:hi], axis=0)
            if (np.unique(ry[core]).size < RUN // 2
                    or np.hypot(*(b - whole)) > UNIFORM * np.hypot(*whole)):
                continue  # a core a few rows high, or a background unlike the frame's
            # Across its length an upright object's motion is unsure (the aperture: a
            # rigid fit gave a pole moving along a pan 9 px a frame of vertical motion):
            # it moves vertically as its background.
            rows_, cols_ = far[lo:hi][ry], np.arange(w)[band][rx]
            beside = _beside(field, tau, rows_, band, side, v, b)
            out.append(EdgeObject(side, rows_[core], cols_[core],
                                  (float(v[0]), float(b[1])), (float(b[0]), float(b[1])),
                                  beside[core], (rows_[near], cols_[near], beside[near])))
    return out


def _standing_out(obj: EdgeObject, own: np.ndarray, seen: np.ndarray,
                  scale: tuple[float, float]) -> tuple[EdgeObject, np.ndarray]:
    """Return an object's core; where it is all like the background beside it, what is not.

    The field, blending, carries an object's velocity onto flat background beside it (a
    black wall above a pole entering the frame), whose look is then taken for the
    object's. Where fewer than :data:`RUN` of the core's pixels are unlike the background
    beside them in their row, those and the pixels a little slower (:data:`CORE`,
    ``obj.wider``) that are unlike it are the core, if there are :data:`RUN` of them.
    (Only then: for a core partly background, the look of a dark pole's part alone had a
    rocket's dark details taken for the pole in a neighbour.) Returns the object and the
    look (``seen``, this frame's first plane ``own`` at the core).
    """
    sx, sy = scale

    def unlike(rows: np.ndarray, beside: np.ndarray, look: np.ndarray) -> np.ndarray:
        """Which pixels (``look``) differ from the background beside them in their row."""
        return (beside < 0) | (_unlike(own, look, (beside + 0.5) * sx - 0.5,
                                       (rows + 0.5) * sy - 0.5) > ALIKE)

    assert obj.beside is not None
    whole = seen
    part = unlike(obj.rows, obj.beside, seen)
    if part.sum() >= RUN or obj.wider is None or not obj.wider[0].size:
        return dataclasses.replace(obj, wider=None), whole
    rows, cols, beside = obj.rows[part], obj.cols[part], obj.beside[part]
    seen = seen[part]
    wr, wc, wb = obj.wider
    look = sample_points(own, (wc + 0.5) * sx - 0.5, (wr + 0.5) * sy - 0.5
                         ).astype(np.float32).reshape(wr.size, -1)
    more = unlike(wr, wb, look)
    rows, cols, beside = (np.concatenate([a, b[more]]) for a, b in
                          ((rows, wr), (cols, wc), (beside, wb)))
    seen = np.concatenate([seen, look[more]])
    if rows.size < RUN:  # nothing stands out: as it was
        return dataclasses.replace(obj, wider=None), whole
    order = np.argsort(rows, kind="stable")
    rows, cols, beside, seen = rows[order], cols[order], beside[order], seen[order]
    return dataclasses.replace(obj, rows=rows, cols=cols, beside=beside, wider=None), seen


def _beside(field: np.ndarray, tau: np.ndarray, rows: np.ndarray, band: slice, side: int,
            velocity: np.ndarray, behind: np.ndarray) -> np.ndarray:
    """Per core pixel, the nearest column inward of ``band`` whose field is the background's.

    Along the background's motion a column's velocity (``field / tau``) nearer the
    background's (``behind``) than the object's (``velocity``) is the background beside the
    object; -1 where none is within :data:`BESIDE` columns.
    """
    w = field.shape[1]
    cols = (np.arange(band.stop, min(w, band.stop + BESIDE)) if side < 0
            else np.arange(band.start - 1, max(-1, band.start - 1 - BESIDE), -1))
    out = np.full(rows.size, -1)
    if not cols.size:
        return out
    along = behind / max(float(np.hypot(*behind)), 1e-6)
    gap = abs(float((velocity - behind) @ along))
    uniq, at = np.unique(rows, return_inverse=True)
    vel = field[uniq][:, cols] / tau[uniq, None, None]
    like = np.abs(((vel - behind) * along).sum(axis=2)) < gap / 2
    first = like.argmax(axis=1)
    found = like[np.arange(uniq.size), first]
    return np.where(found, cols[first], -1)[at]


def settled_objects(objects: list[EdgeObject], own: np.ndarray, planes: list[np.ndarray],
                    steps: list[float], grid: tuple[int, int]) -> list[EdgeObject]:
    """Keep the objects a neighbour shows where their velocity carries them, refined.

    An object's field near the side can give a velocity a few pixels off, and then a
    thin pole carried beyond the edge lands beside itself. Its core pixels (of this
    frame's first plane, ``own``) are carried into each neighbour (first planes,
    ``planes``) at the velocity plus offsets of up to :data:`SEARCH` grid pixels along x;
    the share of them within :data:`ALIKE` grey levels of what the neighbour shows there
    is scored, and of the best offsets the one nearest zero kept (the field's own where it
    is among them: a pole matches over a range as wide as itself, whose middle is where
    the core, not the pole, is centred).
    The share counts only the core pixels that the background's velocity does not carry
    onto alike ones: a thin pole's band holds background beside it, which matches at
    the background's velocity and not at the pole's, and a flat region matches anywhere.
    An object whose best share (in the neighbour where most such pixels land inside, at
    least :data:`RUN`) is under :data:`HELD` is dropped: its velocity is not the one the
    pictures show. A kept object's core is what that neighbour showed alike there and not
    where the background's motion carries it, which :func:`objects_beyond` takes for the
    object's look. First, a core all like the background beside it in its rows (a flat
    wall the field gave the object's velocity) is replaced by what of it and of the
    slightly slower pixels is not (:func:`_standing_out`).
    """
    gh, gw = grid
    ph, pw = own.shape[:2]
    sx, sy = pw / gw, ph / gh
    kept = []
    for obj in objects:
        seen = sample_points(own, (obj.cols + 0.5) * sx - 0.5, (obj.rows + 0.5) * sy - 0.5
                       ).astype(np.float32).reshape(obj.rows.size, -1)
        if obj.beside is not None:
            obj, seen = _standing_out(obj, own, seen, (sx, sy))

        def shares(plane: np.ndarray, vx: np.ndarray, vy: float, dt: float,
                   among: np.ndarray | None = None, seen: np.ndarray = seen,
                   obj: EdgeObject = obj) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            """Return, per horizontal velocity of ``vx``, the core pixels carried inside.

            Of those ``among`` (all if None): their count, the share alike (0 for a
            count under :data:`RUN`), and which of all are alike (velocity, pixel).
            """
            lx = obj.cols[None, :] + vx[:, None] * dt
            inside = (lx >= -0.5) & (lx <= gw - 0.5)
            ly = (obj.rows + vy * dt).clip(0, gh - 1)
            there = sample_points(plane, ((lx + 0.5) * sx - 0.5).ravel(),
                                  np.tile((ly + 0.5) * sy - 0.5, vx.size)
                                  ).astype(np.float32).reshape(vx.size, obj.rows.size, -1)
            alike = (np.abs(there - seen[None]).max(axis=2) <= ALIKE) & inside
            counted = inside if among is None else inside & among
            n = counted.sum(axis=1)
            held = n >= RUN
            return (np.where(held, n, 0),
                    np.where(held, (alike & counted).sum(axis=1) / np.maximum(n, 1), 0.0),
                    alike)

        best: tuple[int, float, float] = (0, 0.0, 0.0)  # landed, share, dx
        own_px = np.ones(obj.rows.size, bool)
        offsets = np.arange(-SEARCH, SEARCH + 0.25, 0.5)
        for plane, dt in zip(planes, steps, strict=True):
            # The object's own pixels: those its background's motion does not carry onto
            # alike ones (a band around a thin pole holds background too, and a flat sky
            # matches anywhere).
            mine = ~shares(plane, np.array([obj.behind[0]]), obj.behind[1], dt)[2][0]
            n, a, alike = shares(plane, obj.velocity[0] + offsets, obj.velocity[1], dt, mine)
            landed, top = int(n.max()), float(a.max())
            if landed >= RUN and (landed, top) > best[:2]:
                pick = min(np.flatnonzero(a >= top - 1e-6), key=lambda i: abs(offsets[i]))
                best = (landed, top, float(offsets[pick]))
                own_px = alike[pick] & mine
        if best[1] >= HELD:
            kept.append(dataclasses.replace(
                obj, velocity=(obj.velocity[0] + best[2], obj.velocity[1]),
                rows=obj.rows[own_px], cols=obj.cols[own_px],
                beside=None if obj.beside is None else obj.beside[own_px]))
    return kept


def objects_beyond(parts: list, objects: list[EdgeObject], grid: tuple[int, int],
                   readout: float, reference_row: float, steps: list[float],
                   offsets: list[int], own: np.ndarray | None, planes: list[np.ndarray],
                   decided: np.ndarray | None = None,
                   further: list[np.ndarray | None] | None = None
                   ) -> tuple[list, np.ndarray | None]:
    """Re-target the strip's pixels that an object leaving the frame covers.

    Output pixel ``p`` shows the object if its source under the object's own motion,
    ``s = p + v tau(s_y)`` (:func:`edge_objects`), lies beyond the side the object
    touches, and a neighbour, read at ``s + v dt``, shows there what this frame shows
    of the object where it touches the side (within :data:`ALIKE` grey levels of its
    core's median, on the first plane): the object is nearer, so it covers the background
    there. Rows read after the reference try the previous frame first (the object, moving
    out, was further in), others the next. Where the check fails the pixel keeps its part;
    an object that takes fewer pixels than a band two grid pixels wide and :data:`RUN` rows
    high takes none (a speck at the edge, not an object's continuation). A pixel beyond that
    side whose part reads the neighbour where it shows the object (:func:`_covered`: the
    object, further in then, covers the background the pixel looks for) is read along
    the object's motion instead, which lands beside the object there. And a pixel on the
    object's side whose part reads the neighbour where it shows the object, but whose
    place under the object's motion it does not (:func:`_overtaken`: the object, faster,
    overtook the background there) is read two frames away on that side along the
    background's motion where that frame shows no object there (``further``: the object
    is further ahead), else left as warped (unseen). A pixel on the object's
    side read where the object's motion, not the background's, carries it (the flow past
    the edge is the object's beside it) and showing no object there is read along the
    background's motion instead (:func:`_behind`).

    Parameters
    ----------
    parts : list
        :func:`neighbour_sources` of one plane.
    objects : list of EdgeObject
    grid : tuple of int
        The field's grid (h, w).
    readout, reference_row : float
        The timing (``reference_row`` in grid rows).
    steps : list of float
        Per neighbour, its time less this frame's (frame intervals).
    offsets : list of int
        Per neighbour, -1 (previous) or 1 (next).
    own : ndarray, optional
        This frame's first plane (top-bottom) when ``parts`` are the first plane's.
    planes : list of ndarray
        The neighbours' planes of this size.
    decided : ndarray, optional
        For a plane other than the first: the first plane's decisions (returned when it
        was done), read at the nearest of its pixels.
    further : list, optional
        Per neighbour, the plane two frames away on its side or None (part ``n + 1 + i``).

    Returns
    -------
    parts : list
        The parts, with the object's pixels moved to the neighbour that shows it.
    decided : ndarray of int8 or None
        On the first plane: per pixel, 1 + the neighbour that showed the object, -1 where
        left as warped, ``_REREAD`` where re-read along the background's motion, 0 where
        none; None where no pixel changed.
    """
    if not objects:
        return parts, decided
    ph, pw = planes[0].shape[:2]
    gh, gw = grid
    sx, sy = pw / gw, ph / gh
    k = readout / gh
    # Besides the strip, the pixels whose source the background's motion keeps inside but
    # an object's (nearer: faster) carries beyond the side (-2: as warped, unless taken).
    wider = np.zeros((ph, pw), bool)
    cols = np.arange(pw)
    s_rows = ((np.arange(ph) + 0.5) / sy - 0.5)[:, None]
    for obj in objects:
        reach = _source(np.zeros(1), s_rows, obj.velocity, reference_row, k)[0]
        edge = ((gw - 0.5 if obj.side > 0 else -0.5) - reach + 0.5) * sx - 0.5
        wider |= cols >= edge if obj.side > 0 else cols <= edge
    for p in parts:
        wider[p[1], p[2]] = False
    wy, wx = np.nonzero(wider)
    parts = [*parts, (-2, wy, wx, wx.astype(np.float32), wy.astype(np.float32))]
    ys, xs, nx, ny = (np.concatenate([p[i] for p in parts]) for i in range(1, 5))
    ks = np.concatenate([np.full(p[1].size, p[0]) for p in parts])
    gx, gy = (xs + 0.5) / sx - 0.5, (ys + 0.5) / sy - 0.5
    first = decided is None
    mark = np.zeros((ph, pw), np.int8) if decided is None else decided
    if not first:
        dh, dw = mark.shape
        at = mark[np.clip(((ys + 0.5) * dh / ph).astype(int), 0, dh - 1),
                  np.clip(((xs + 0.5) * dw / pw).astype(int), 0, dw - 1)]
    free = np.ones(ys.size, bool)
    reread_any = False
    least = 2 * RUN * sx * sy  # plane pixels: a band two grid pixels wide, RUN rows high
    for obj in objects:
        vx, vy = obj.velocity
        s_x, s_y = _source(gx, gy, obj.velocity, reference_row, k)
        if first:
            assert own is not None
            look = np.median(sample_points(own, (obj.cols + 0.5) * sx - 0.5,
                                           (obj.rows + 0.5) * sy - 0.5)
                             .reshape(obj.rows.size, -1).astype(np.float32), axis=0)
        beyond = (s_x > gw - 0.5) if obj.side > 0 else (s_x < -0.5)
        open_ = free & beyond
        late = s_y >= reference_row
        taken = []
        for rank in (0, 1):  # each pixel's preferred neighbour first, then the other
            for i, offset in enumerate(offsets):
                wants = late if offset < 0 else ~late
                # (an upright object's vertical motion is unsure: held inside the frame)
                lx, ly = s_x + vx * steps[i], (s_y + vy * steps[i]).clip(0, gh - 1)
                idx = np.flatnonzero(open_ & (wants if rank == 0 else ~wants)
                                     & (lx >= -0.5) & (lx <= gw - 0.5))
                if not idx.size:
                    continue
                qx, qy = (lx[idx] + 0.5) * sx - 0.5, (ly[idx] + 0.5) * sy - 0.5
                if first:  # the object as this frame saw it: its core's median look
                    alike = _unlike(planes[i], look, qx, qy) <= ALIKE
                else:
                    alike = at[idx] == i + 1
                taken.append((idx[alike], i, qx[alike], qy[alike]))
                open_[idx[alike]] = False
        near = free & (ks >= 0) & ((gx > gw / 2) if obj.side > 0 else (gx < gw / 2))
        for t in taken:
            near[t[0]] = False
        if first:  # (the other planes follow the first's decisions)
            idx = np.flatnonzero(near)
            reread = np.zeros(ks.size, bool)
            for i in range(len(offsets)):
                at_i = idx[ks[idx] == i]
                if at_i.size:  # (not at the object's blurred outline either)
                    far = _unlike_near(planes[i], look, nx[at_i], ny[at_i],
                                       MISSED * sx) > ALIKE
                    reread[at_i[far]] = True
        else:
            reread = near & (at == _REREAD)
        moved = _behind(near & reread, ks, nx, ny, (gx, gy), obj, steps, (sx, sy), grid,
                        readout, reference_row)
        if first:
            mark[ys[moved], xs[moved]] = _REREAD
        reread_any |= moved.size > 0
        # The background's pixels on its side whose neighbour sample shows it where its own
        # motion says they are not it: it overtook the background there. Left as warped.
        for i in range(len(offsets)):
            idx = np.flatnonzero(near & (ks == i))
            two = len(offsets) + 1 + i  # the frame two away on this side, as a part
            if first and idx.size:
                idx = idx[_overtaken(planes[i], look, nx[idx], ny[idx],
                                     s_x[idx] + vx * steps[i],
                                     (s_y[idx] + vy * steps[i]).clip(0, gh - 1), (sx, sy), gw)]
                mark[ys[idx], xs[idx]] = -1
            elif idx.size:
                idx = idx[(at[idx] == -1) | (at[idx] == two + 1)]
            ks[idx], free[idx] = -1, False
            (bx, by), away = obj.behind, further[i] if further else None
            if away is not None and idx.size and abs(by) <= abs(bx) / 4:
                qx, qy = _source(gx[idx], gy[idx], obj.behind, reference_row, k)  # (a pan's)
                qx = (qx + 2 * steps[i] * bx + 0.5) * sx - 0.5
                qy = (qy + 2 * steps[i] * by + 0.5) * sy - 0.5
                ok = ((qx >= -0.5) & (qx <= pw - 0.5) & (qy >= -0.5) & (qy <= ph - 0.5)
                      & (_unlike_near(away, look, qx, qy, MISSED * sx) > ALIKE)
                      if first else at[idx] == two + 1)
                idx = idx[ok]
                ks[idx], nx[idx], ny[idx] = two, qx[ok], qy[ok]
                if first:
                    mark[ys[idx], xs[idx]] = two + 1
        if first and sum(t[0].size for t in taken) < least:
            continue  # a few pixels: no object's continuation, a speck
        for idx, i, qx, qy in taken:
            ks[idx], nx[idx], ny[idx] = i, qx, qy
            free[idx] = False
            if first:
                mark[ys[idx], xs[idx]] = i + 1
        if first:  # and the background's pixels read where a neighbour shows it
            for i, idx in _covered(taken, np.flatnonzero(beyond & free), ks, nx, ny, ph):
                lx, ly = s_x[idx] + vx * steps[i], (s_y[idx] + vy * steps[i]).clip(0, gh - 1)
                inside = (lx >= -0.5) & (lx <= gw - 0.5)
                idx = idx[inside]
                ks[idx], free[idx] = i, False
                nx[idx] = (lx[inside] + 0.5) * sx - 0.5
                ny[idx] = (ly[inside] + 0.5) * sy - 0.5
                mark[ys[idx], xs[idx]] = i + 1
    if free.all() and not reread_any:
        return parts[:-1], (None if first else mark)
    out = [(int(i), ys[ks == i], xs[ks == i], nx[ks == i], ny[ks == i])
           for i in np.unique(ks) if i > -2]
    return out, mark


def _behind(near: np.ndarray, ks: np.ndarray, nx: np.ndarray, ny: np.ndarray,
            at: tuple[np.ndarray, np.ndarray], obj: EdgeObject, steps: list[float],
            scale: tuple[float, float], grid: tuple[int, int], readout: float,
            reference_row: float) -> np.ndarray:
    """Re-read along the background's motion the strip pixels read along the object's.

    :func:`neighbour_sources` carries the flow past the edge as the flow a few pixels in,
    which beside an object touching the side is the object's (the flow blends across its
    outline): the background beyond the edge is then read where the object's motion,
    not its own, carries it. Of the pixels ``near`` (background on the object's side read
    from neighbour ``ks`` at ``(nx, ny)``, plane pixels), those whose sample lies nearer
    (along x) where ``obj.velocity`` carries them than where ``obj.behind`` does are
    moved, in place, to the latter, where it lies inside the frame. ``at``: the pixels'
    places (grid pixels).
    """
    idx = np.flatnonzero(near)
    if not idx.size:
        return idx
    gx, gy = at[0][idx], at[1][idx]
    sx, sy = scale
    gh, gw = grid
    k = readout / gh
    step = np.asarray(steps, np.float64)[ks[idx]]
    reads = []
    for v in (obj.velocity, obj.behind):
        s_x, s_y = _source(gx, gy, v, reference_row, k)
        reads.append((s_x + v[0] * step, (s_y + v[1] * step).clip(0, gh - 1)))
    (ox, _), (bx, by) = reads
    read = (nx[idx] + 0.5) / sx - 0.5
    move = (np.abs(read - ox) < np.abs(read - bx)) & (bx >= -0.5) & (bx <= gw - 0.5)
    idx = idx[move]
    nx[idx] = (bx[move] + 0.5) * sx - 0.5
    ny[idx] = (by[move] + 0.5) * sy - 0.5
    return idx


def _source(gx: np.ndarray, gy: np.ndarray, velocity: tuple[float, float],
            reference_row: float, k: float) -> tuple[np.ndarray, np.ndarray]:
    """Return where this frame read a point shown at ``(gx, gy)`` at the reference time.

    The point moves at ``velocity``: ``s = p + v tau(s_y)``, ``tau = (s_y - reference_row)
    k`` (grid pixels; ``k`` the readout a grid row).
    """
    vx, vy = velocity
    s_y = (gy - vy * reference_row * k) / (1.0 - vy * k)
    return gx + vx * (s_y - reference_row) * k, s_y


def _unlike_near(plane: np.ndarray, look: np.ndarray, x: np.ndarray, y: np.ndarray,
                 reach: float) -> np.ndarray:
    """Return the least :func:`_unlike` at ``(x, y)`` and ``reach`` either side along x."""
    return np.min([_unlike(plane, look, x + d, y) for d in (-reach, 0.0, reach)], axis=0)


def _unlike(plane: np.ndarray, look: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Largest grey-level difference (over channels) of ``plane`` at ``(x, y)`` from ``look``."""
    return np.abs(sample_points(plane, x, y).reshape(x.size, -1).astype(np.float32)
                  - look).max(axis=1)


def _overtaken(plane: np.ndarray, look: np.ndarray, nx: np.ndarray, ny: np.ndarray,
               lx: np.ndarray, ly: np.ndarray, scale: tuple[float, float], gw: int
               ) -> np.ndarray:
    """Which background samples ``(nx, ny)`` of a neighbour show an object that is not there.

    The pixel's own part reads the neighbour's ``plane`` at ``(nx, ny)`` (plane pixels);
    the object's motion carries the pixel to ``(lx, ly)`` there (grid pixels). Where the
    sample looks like the object (within :data:`ALIKE` grey levels of its ``look``, or,
    at its blurred edge, nearer it than half-way to what the object's own landing shows,
    up to three times that) and the object's own landing does not (unlike it by three
    times :data:`ALIKE` within :data:`MISSED` pixels along x: its velocity is unsure), the
    object, nearer and faster, covers there the background the pixel looks for: a pole
    that overtook it at the frame's edge. Returns a bool mask of the samples.
    """
    sx, sy = scale
    inside = (lx >= -0.5) & (lx <= gw - 0.5)
    shows = _unlike(plane, look, nx, ny)
    other = _unlike_near(plane, look, (lx + 0.5) * sx - 0.5, (ly + 0.5) * sy - 0.5,
                         MISSED * sx)
    return inside & (other > 3 * ALIKE) & (
        shows <= np.maximum(ALIKE, np.minimum(other / 2, 3 * ALIKE)))


def _covered(taken: list, cand: np.ndarray, ks: np.ndarray, nx: np.ndarray, ny: np.ndarray,
             ph: int) -> list[tuple[int, np.ndarray]]:
    """Of the pixels ``cand``, those whose part reads a neighbour where it shows the object.

    ``taken``: per neighbour ``i``, where the object's pixels were found in it (``qx,
    qy``, plane pixels); a pixel of ``cand`` whose part (``ks``) reads that neighbour at
    ``(nx, ny)`` within a pixel of the object's span on that row reads the object, which
    covers there what the pixel's own (background) motion looks for.
    """
    out = []
    for i in sorted({t[1] for t in taken}):
        qx = np.concatenate([t[2] for t in taken if t[1] == i])
        if not qx.size:
            continue
        row = np.rint(np.concatenate([t[3] for t in taken if t[1] == i])).astype(int)
        lo, hi = np.full(ph, np.inf), np.full(ph, -np.inf)
        np.minimum.at(lo, row.clip(0, ph - 1), qx)
        np.maximum.at(hi, row.clip(0, ph - 1), qx)
        mine = cand[ks[cand] == i]
        r = np.rint(ny[mine]).astype(int).clip(0, ph - 1)
        out.append((i, mine[(nx[mine] >= lo[r] - 1.0) & (nx[mine] <= hi[r] + 1.0)]))
    return out

