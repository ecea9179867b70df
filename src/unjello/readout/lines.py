"""Readout from lines that are straight in the world: the lean of near-vertical edges.

A rolling-shutter frame read top to bottom images row ``y`` at ``t_n + rho y / h``, so
content moving sideways at ``u`` px per frame interval is shifted by ``u rho y / h``
more on each later row: a line whose own lean is ``a`` (dx/dy) appears with the lean

    l = a + rho u / h

(to first order; vertical motion scales ``a`` by ``1 - rho w / h``, a second-order
term). Two cues follow (:func:`line_readout`), each with an uncertainty:

- **tracked** -- the same segment followed from frame to frame changes its lean with
  its velocity by exactly ``rho du / h``, whatever its own lean, the camera's roll or
  the perspective: a regression of lean on velocity within each track (fixed effects,
  robust weights), pooled over the tracks. Hand shake, a pan that speeds up or slows
  down, a turning vehicle give ``du``; its standard error is clustered by frame (the
  segments of one frame share its motion's errors).
- **vertical prior** -- where there is no ``du`` (two frames, a steady pan), the
  segments are taken to be vertical in the world once the camera's roll (the median
  slope of the near-horizontal segments, which the shutter does not tilt) is taken
  out. The scene's own lean then adds ``h a / u`` to the estimate: its spread on real
  footage, :data:`SCENE_LEAN` (measured on the research pairs' global-shutter truth,
  ``docs/readout.md``), is part of the uncertainty, so slow motion leaves it unknown.

Frames are in the sensor's top-bottom orientation (:func:`unjello.timing.to_top_bottom`):
for a left-right scan the "vertical" lines are the world's horizontals.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["SCENE_LEAN", "CONFIDENT", "LineCue", "frame_segments", "line_readout",
           "confidence_of"]

#: RMS lean (dx/dy) of near-vertical segments of real scenes after the camera roll is
#: taken out: perspective, leaning objects (``docs/readout.md``).
SCENE_LEAN = 0.09
#: The uncertainty (one standard deviation, fraction of the frame interval) at which an
#: estimate counts as confident: within 0.05 at two sigma.
CONFIDENT = 0.025
# Segments: near-vertical within this |dx/dy|, at least this share of the frame's height
# (and px); the roll from near-horizontals within this |dy/dx| and share of the width.
_MAX_LEAN, _MIN_LENGTH, _MIN_PX = 0.35, 0.1, 12.0
_MAX_SLOPE, _MIN_WIDTH = 0.12, 0.025
# LSD runs on copies at most this wide.
_LSD_WIDTH = 960
# Matching a segment in the next frame: lean within, distance of the predicted middle
# to the line within (px of the analysed frame), rows shared at least.
_MATCH_LEAN, _MATCH_PX, _MATCH_OVERLAP = 0.04, 2.5, 0.6
# The RMS change of velocity (px per frame interval) the tracked cue needs.
_MIN_CHANGE = 0.75
# ... over at least this many frames' worth of the change (an effective count).
_MIN_FRAMES = 3.5
# ... and in at least this many tracks (the scatter of fewer says little of their error).
_MIN_TRACKS = 8


@dataclass(frozen=True)
class LineCue:
    """What the straight lines say of the readout.

    Attributes
    ----------
    readout : float
        The estimate (fraction of the frame interval); NaN where there is none.
    uncertainty : float
        One standard deviation of it; ``inf`` where there is none.
    kind : {'tracked', 'vertical prior', 'none'}
        The cue it comes from.
    segments, tracks : int
        Near-vertical segments found, and tracks of three frames or more used.
    """

    readout: float
    uncertainty: float
    kind: str
    segments: int = 0
    tracks: int = 0

    @property
    def confident(self) -> bool:
        """Whether the uncertainty is within :data:`CONFIDENT`."""
        return bool(self.uncertainty <= CONFIDENT)


def confidence_of(uncertainty: float) -> float:
    """Return a 0-1 confidence for an uncertainty: 0.5 at :data:`CONFIDENT`, 1 at zero."""
    if not np.isfinite(uncertainty):
        return 0.0
    return float(1.0 / (1.0 + (uncertainty / CONFIDENT) ** 2))


_LSD = None


def frame_segments(grey: np.ndarray) -> tuple[np.ndarray, float | None]:
    """Near-vertical line segments of a frame, and the camera's roll from its horizontals.

    Parameters
    ----------
    grey : ndarray of shape (h, w), 0-255
        The frame, top-bottom orientation.

    Returns
    -------
    segments : ndarray of shape (n, 6)
        ``x_mid, y_mid, lean (dx/dy), length, y_top, y_bottom`` in the frame's pixels.
    roll : float or None
        Length-weighted median slope (dy/dx) of the near-horizontal segments; None with
        fewer than three.
    """
    global _LSD
    if _LSD is None:
        _LSD = cv2.createLineSegmentDetector()
    h, w = grey.shape
    k = min(1.0, _LSD_WIDTH / w)
    g8 = np.clip(grey, 0, 255).astype(np.uint8)
    if k < 1.0:
        g8 = cv2.resize(g8, (round(w * k), round(h * k)), interpolation=cv2.INTER_AREA)
    found = _LSD.detect(g8)[0]
    lines = (np.zeros((0, 4)) if found is None else found.reshape(-1, 4).astype(np.float64)) / k
    dx, dy = lines[:, 2] - lines[:, 0], lines[:, 3] - lines[:, 1]
    length = np.hypot(dx, dy)
    flat = (np.abs(dy) <= _MAX_SLOPE * np.abs(dx)) & (length >= max(_MIN_PX, _MIN_WIDTH * w))
    roll = (_weighted_median(dy[flat] / dx[flat], length[flat]) if flat.sum() >= 3 else None)
    upright = (np.abs(dx) <= _MAX_LEAN * np.abs(dy)) & (length >= max(_MIN_PX, _MIN_LENGTH * h))
    lines, dx, dy, length = lines[upright], dx[upright], dy[upright], length[upright]
    top = np.minimum(lines[:, 1], lines[:, 3])
    bottom = np.maximum(lines[:, 1], lines[:, 3])
    segs = np.stack([(lines[:, 0] + lines[:, 2]) / 2, (lines[:, 1] + lines[:, 3]) / 2,
                     dx / dy, length, top, bottom], axis=1)
    return segs, roll


def _weighted_median(values: np.ndarray, weights: np.ndarray) -> float:
    order = np.argsort(values)
    cum = np.cumsum(weights[order])
    return float(values[order][np.searchsorted(cum, 0.5 * cum[-1])])


def _sample(field: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Bilinear samples of a (h, w, 2) field at points (edge repeated)."""
    mx = np.asarray(x, np.float32).reshape(1, -1)
    my = np.asarray(y, np.float32).reshape(1, -1)
    return cv2.remap(np.ascontiguousarray(field, np.float32), mx, my, cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_REPLICATE)[0]


def _match(a: np.ndarray, b: np.ndarray, shift: np.ndarray) -> list[tuple[int, int]]:
    """Pairs (i, j): segment ``i`` of a frame is segment ``j`` of the next (mutual best).

    ``shift`` (n, 2) is where each segment's middle moved (the flow at it).
    """
    if not len(a) or not len(b):
        return []
    px, py = a[:, 0] + shift[:, 0], a[:, 1] + shift[:, 1]
    # Distance of each predicted middle from each line of b, along the row.
    dist = np.abs(px[:, None] - (b[None, :, 0] + b[None, :, 2] * (py[:, None] - b[None, :, 1])))
    lean = np.abs(a[:, None, 2] - b[None, :, 2])
    top = np.maximum(a[:, None, 4] + shift[:, None, 1], b[None, :, 4])
    bottom = np.minimum(a[:, None, 5] + shift[:, None, 1], b[None, :, 5])
    span = np.minimum((a[:, 5] - a[:, 4])[:, None], (b[:, 5] - b[:, 4])[None, :])
    ok = (dist <= _MATCH_PX) & (lean <= _MATCH_LEAN) & (bottom - top >= _MATCH_OVERLAP * span)
    cost = np.where(ok, dist + 20.0 * lean, np.inf)
    best_j = np.argmin(cost, axis=1)
    best_i = np.argmin(cost, axis=0)
    return [(i, int(j)) for i, j in enumerate(best_j)
            if np.isfinite(cost[i, j]) and best_i[j] == i]


def _moves(segs: np.ndarray, flow: np.ndarray, points: int = 9) -> np.ndarray:
    """Each segment's move to the next frame: the flow averaged along it, (n, 2)."""
    if not len(segs):
        return np.zeros((0, 2))
    along = np.linspace(-0.4, 0.4, points)
    span = segs[:, 5] - segs[:, 4]
    ys = segs[:, 1:2] + along[None, :] * span[:, None]
    xs = segs[:, 0:1] + segs[:, 2:3] * (ys - segs[:, 1:2])
    return _sample(flow, xs.ravel(), ys.ravel()).reshape(len(segs), points, 2).mean(axis=1)


def _tracks(segs: list[np.ndarray], moves: list[np.ndarray]) -> list[list[tuple[int, int]]]:
    """Chain matched segments into tracks: lists of (frame, segment index)."""
    open_tracks: dict[int, list[tuple[int, int]]] = {}
    done: list[list[tuple[int, int]]] = []
    for k in range(len(segs) - 1):
        a = segs[k]
        pairs = dict(_match(a, segs[k + 1], moves[k]))
        nxt: dict[int, list[tuple[int, int]]] = {}
        for i in range(len(a)):
            track = open_tracks.pop(i, [(k, i)])
            if i in pairs:
                track.append((k + 1, pairs[i]))
                nxt[pairs[i]] = track
            else:
                done.append(track)
        open_tracks = nxt
    done.extend(open_tracks.values())
    return done


def _tracked(segs: list[np.ndarray], moves: list[np.ndarray],
             tracks: list[list[tuple[int, int]]], times: np.ndarray, h: int
             ) -> tuple[float, float, int]:
    """Lean against motion within tracks: rho, its sigma and the tracks used.

    Over frames ``n - 1, n, n + 1`` of a track, Simpson's rule ties the leans (the
    velocities ``(l - a) h / rho`` at the three times) to the displacement between the
    outer two: ``(l_{n-1} + 4 l_n + l_{n+1}) / 6 = a + (rho / h) (p_{n+1} - p_{n-1}) / 2``
    (exact for a cubic path). The displacement is the flow averaged along the segment
    (:func:`_moves`): far less noisy than the segments' own positions, whose noise
    would bias the slope towards zero. The unknown lean ``a`` of each track drops out by
    centring (fixed effects); the slope is fitted with Huber weights.
    """
    xs, ys, frames = [], [], []
    for track in (t for t in tracks if len(t) >= 3):
        rows = np.array([segs[k][i] for k, i in track])
        t = times[[k for k, _ in track]]
        step = np.array([moves[k][i, 0] for k, i in track[:-1]])  # x move to the next frame
        lean = rows[:, 2]
        speed = (step[1:] + step[:-1]) / (t[2:] - t[:-2])
        mean_lean = (lean[:-2] + 4 * lean[1:-1] + lean[2:]) / 6
        xs.append(speed - speed.mean())
        ys.append(mean_lean - mean_lean.mean())
        frames.append(np.array([k for k, _ in track[1:-1]]))
    if not xs:
        return float("nan"), float("inf"), 0
    x, y = np.concatenate(xs), np.concatenate(ys)
    frame = np.concatenate(frames)
    n_tracks = len(xs)
    # Without a change of velocity of a px per frame interval or so (in most tracks, not
    # a few mismatched ones), nothing to tell.
    spread = 1.4826 * float(np.median(np.abs(x)))
    if n_tracks < _MIN_TRACKS or spread < _MIN_CHANGE:
        return float("nan"), float("inf"), n_tracks
    weight = (np.abs(x) <= 4.0 * spread).astype(np.float64)  # no lever for a mismatch
    for _ in range(6):  # Huber weights on the residuals
        slope = float(np.sum(weight * x * y) / np.sum(weight * x * x))
        r = y - slope * x
        scale = 1.4826 * float(np.median(np.abs(r))) + 1e-6
        weight = (np.abs(x) <= 4.0 * spread) / np.maximum(1.0, np.abs(r) / (2.0 * scale))
    # Standard error clustered by frame (a sandwich): the segments of a frame share errors.
    score = np.bincount(frame, weights=weight * x * r)
    dof = len(x) / max(len(x) - n_tracks - 1, 1)
    se = float(np.sqrt(dof * np.sum(score ** 2)) / np.sum(weight * x * x))
    # The change of velocity must be spread over several frames: where one or two hold
    # it (a pan that stops, a start from still), it is a jump Simpson's rule does not
    # follow, and their shared error is not seen in the scatter.
    lever = np.bincount(frame, weights=weight * x * x)
    if float(lever.sum() ** 2 / np.sum(lever ** 2)) < _MIN_FRAMES:
        return float("nan"), float("inf"), n_tracks
    return slope * h, se * h, n_tracks


def line_readout(grey: list[np.ndarray], times: np.ndarray, flows: list[np.ndarray]
                 ) -> LineCue:
    """Estimate the readout ratio from the lean of near-vertical segments (module notes).

    Parameters
    ----------
    grey : list of ndarray of shape (h, w), 0-255
        Consecutive frames, top-bottom orientation.
    times : ndarray of shape (n,)
        Their start times, frame intervals.
    flows : list of ndarray of shape (h, w, 2)
        ``n - 1`` flows from each frame to the next (``a(s) ~ b(s + F(s))``: a point at
        ``s`` moves by ``F(s)``).

    Returns
    -------
    LineCue
        The tracked cue where it is the more certain, else the vertical prior.
    """
    times = np.asarray(times, np.float64)
    found = [frame_segments(g) for g in grey]
    segs = [s for s, _ in found]
    rolls = [r for _, r in found]
    n_segs = int(sum(len(s) for s in segs))
    if len(grey) < 2 or n_segs < 3:
        return LineCue(float("nan"), float("inf"), "none", n_segs)
    h = grey[0].shape[0]
    moves = [_moves(segs[k], flows[k]) for k in range(len(flows))]
    tracks = _tracks(segs, moves)
    cues = []
    if len(grey) >= 3:
        rho, sigma, n_tracks = _tracked(segs, moves, tracks, times, h)
        if np.isfinite(sigma):
            cues.append(LineCue(float(rho), sigma, "tracked", n_segs, n_tracks))
    prior = _vertical_prior(segs, rolls, flows, h)
    if prior is not None:
        cues.append(LineCue(prior[0], prior[1], "vertical prior", n_segs, 0))
    if not cues:
        return LineCue(float("nan"), float("inf"), "none", n_segs)
    return min(cues, key=lambda c: c.uncertainty)


def _vertical_prior(segs: list[np.ndarray], rolls: list[float | None],
                    flows: list[np.ndarray], h: int) -> tuple[float, float] | None:
    """Readout from taking the segments as vertical once the roll is out: rho, sigma."""
    est, wgt, speed = [], [], []
    for k, s in enumerate(segs):
        if not len(s):
            continue
        # The velocity of each segment: the flow to the next frame (the last: from the one
        # before), a displacement over one frame interval.
        vel = _sample(flows[min(k, len(flows) - 1)], s[:, 0], s[:, 1])[:, 0]
        moving = np.abs(vel) >= 1.0
        roll = rolls[k] or 0.0
        est.append((s[moving, 2] + roll) * h / vel[moving])
        wgt.append(s[moving, 3] * vel[moving] ** 2)  # a lean error counts less where fast
        speed.append(vel[moving])
    if not est or sum(len(e) for e in est) < 3:
        return None
    e, w, v = np.concatenate(est), np.concatenate(wgt), np.concatenate(speed)
    rho = _weighted_median(e, w)
    spread = 1.4826 * _weighted_median(np.abs(e - rho), w)
    n_eff = float(w.sum() ** 2 / np.sum(w ** 2))
    u_rms = float(np.sqrt(np.sum(w * v ** 2) / w.sum()))
    sigma = float(np.hypot(spread / np.sqrt(n_eff), h * SCENE_LEAN / u_rms))
    return float(rho), sigma
