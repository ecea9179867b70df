"""Vibration near or above the frame rate (drone "jello"): detection and sinusoids.

Hand shake and pans change slowly within a frame; the vibration of a drone's or a car's
mount (20-40 Hz) changes from scanline to scanline. :func:`vibration_level` measures how
much the row flows of consecutive frame pairs wobble within a frame (what both halves of
the frame share, and what they do not: the noise), :func:`wobble_test` whether that is
vibration, and :func:`choose_model` decides from the first frame pairs of a stretch,
with that test and a comparison of the two models on the half of the frame each was not
fitted on, whether the dense method switches to :data:`VIBRATION`: a one-second window
and a few sinusoids of free frequency picked by :func:`sinusoid_pursuit` and solved with
the camera trajectory (:func:`unjello.motion.dense.camera.solve_camera_trajectory`).
:func:`detect_vibration` is the wobble test alone, for the readout's estimate.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import cv2
import numpy as np

from ..flow.dis import ROW_AGREE, row_flows
from .camera import solve_camera_trajectory

__all__ = ["VIBRATION", "MAX_CYCLES", "PROBE_CONTRAST", "PROBE_WAIT", "PROBE_TEXTURE", "SHARE",
           "SIGNAL", "PREFER", "VISIBLE", "vibration_level", "wobble_test",
           "SINE_RIDGE", "detect_vibration", "choose_model", "probe_pair", "sinusoid_pursuit",
           "pick_frequencies", "refine_frequencies", "REFINE_REACH", "REFINE_STEP",
           "REFINE_ROUNDS"]

#: Settings for vibration near or above the frame rate (drone "jello").
#: (``docs/tuning.md#vibration``)
VIBRATION: dict[str, Any] = {"history": 16, "window": 16, "smoothness": 1e-7, "sinusoids": 6,
                             "refinement": None, "detail": "full"}

#: Ridge on a sinusoid's amplitude, relative to the total weight, when vibration frequencies are
#: picked: one the frame differences barely see must not be picked for noise (``docs/tuning.md``).
SINE_RIDGE = 1e-3

#: A vibration frequency is refined within this many cycles a frame interval of the pursuit's
#: pick, on a grid this fine, over all ROUNDS times (``docs/tuning.md#refine_reach``).
REFINE_REACH, REFINE_STEP, REFINE_ROUNDS = 0.005, 0.0005, 2

#: The highest vibration frequency the model looks for, in cycles per frame interval: 100 Hz at 24
#: fps. (``docs/tuning.md#max_cycles``)
MAX_CYCLES = 4.5

#: The wobble test: vibration is at least SHARE of the non-steady row flow both halves share,
#: and SIGNAL times what they do not (:func:`wobble_test`; ``docs/tuning.md#share``).
SHARE, SIGNAL = 0.4, 3.0

#: The vibration model, fitted to one half's row flows, predicts the other half's with at
#: most this share of the smooth model's error (:func:`choose_model`; ``docs/tuning.md#prefer``).
PREFER = 0.7
#: ... and the smooth model misses the held-out half by at least this much (px).
#: (``docs/tuning.md#visible``)
VISIBLE = 0.1

#: A wobble above this one. (``docs/tuning.md#_wobble_max``)
_WOBBLE_MAX = 0.03

#: Pairs enter the vibration test where both frames have this grey-level deviation (a fade's
#: noise read as vibration), waiting PROBE_WAIT x probe pairs (``docs/tuning.md#probe_contrast``).
PROBE_CONTRAST, PROBE_WAIT = 6.0, 2

#: Only pixels of two-dimensional texture enter the test (``flow.dis.textured``): along an edge the
#: flow is not measured but filled in (the aperture problem). (``docs/tuning.md#probe_texture``)
PROBE_TEXTURE = 0.05


def vibration_level(left: list[tuple[np.ndarray, np.ndarray]],
                    right: list[tuple[np.ndarray, np.ndarray]], height: int
                    ) -> tuple[float, float, float]:
    """How much the row flows of consecutive frame pairs wobble within a frame.

    The part of each row's flow that is the same in every pair (perspective, parallax
    of a steady pan) is removed; the rest, in scanline order (time, for a readout near
    one frame), is split into its slow part (a running mean over one frame) and the
    wobble around it. Hand shake and pans are slow within a frame; vibration near or
    above the frame rate is not. Vibration moves whole rows: the wobble is measured as
    what the left and right halves of the frame share (their cross-power), so a nearer
    layer or a moving object sliding through the rows of one half does not count; what
    they do not share is the measurement's own noise.

    Rows are used where both halves gave a flow in at least half of the pairs; a pair's
    other rows are filled in from the rows around (heavy jello shears the frame, and the
    flow of some rows fails the consistency check in some pairs).

    Parameters
    ----------
    left, right : list of (row indices, row flows[, row weights])
        Per pair, in order: :func:`row_flows` of the left and of the right half. With
        weights, each row counts by the product of its halves' (the share of the row's
        pixels that agree with its flow: a row over flat sky that a pole's edge alone
        gave a flow barely counts).
    height : int
        Rows per frame.

    Returns
    -------
    wobble : float
        RMS of the shared wobble, as a fraction of the frame height.
    share : float
        Its share of the RMS of the non-stationary flow (0-1).
    noise : float
        RMS of what the halves' wobbles do not share (half their difference), as a
        fraction of the frame height.
    """
    pairs = len(left)
    if pairs < 3 or pairs != len(right):
        return 0.0, 0.0, 0.0
    per = np.full((2, pairs, height, 2), np.nan)
    weight = np.zeros((2, pairs, height))
    for side, rows in enumerate((left, right)):
        for k, (y, flow, *w) in enumerate(rows):
            per[side, k, y.astype(np.int64)] = flow
            weight[side, k, y.astype(np.int64)] = w[0] if w else 1.0
    both = np.isfinite(per).all(axis=(0, 3))  # (pairs, rows)
    seen = both.sum(axis=0) >= max(3, (pairs + 1) // 2)
    n = int(seen.sum())
    keep = both[:, seen].sum(axis=1) >= n // 2  # pairs with most of those rows
    if n < height // 4 or keep.sum() < 3:
        return 0.0, 0.0, 0.0
    sub = per[:, keep][:, :, seen]
    ok = both[keep][:, seen]
    moving = sub - np.nanmean(np.where(ok[None, :, :, None], sub, np.nan), axis=1,
                              keepdims=True)
    idx = np.arange(n)
    for side in range(2):  # a pair's missing rows from the rows around them
        for k in range(moving.shape[1]):
            for c in range(2):
                moving[side, k, ~ok[k], c] = np.interp(idx[~ok[k]], idx[ok[k]],
                                                       moving[side, k, ok[k], c])
    moving = moving.reshape(2, -1, 2).astype(np.float64)
    # Each row counts by both halves' weights (a filled-in row not at all).
    wgt = (np.where(ok, weight[0][keep][:, seen] * weight[1][keep][:, seen], 0.0)).ravel()
    wgt = wgt / max(float(wgt.sum()), 1e-12)
    wobble = [m - cv2.blur(m[:, None, :], (1, n), borderType=cv2.BORDER_REPLICATE)[:, 0, :]
              for m in moving]
    shared = float(np.sqrt(max(0.0, ((wobble[0] * wobble[1]).sum(axis=1) * wgt).sum())))
    total = float(np.sqrt(max(0.0, ((moving[0] * moving[1]).sum(axis=1) * wgt).sum())))
    noise = float(np.sqrt(((((wobble[0] - wobble[1]) / 2) ** 2).sum(axis=1) * wgt).sum()))
    return (shared / height, min(1.0, shared / total) if total > 0 else 0.0,
            noise / height)


def wobble_test(left: list[tuple[np.ndarray, np.ndarray]],
                right: list[tuple[np.ndarray, np.ndarray]], height: int
                ) -> tuple[bool, dict[str, float]]:
    """Whether the row flows wobble as vibration does (:func:`vibration_level`).

    The shared wobble makes up at least :data:`SHARE` of the non-steady flow, stands at
    least :data:`SIGNAL` times above what the halves do not share, and stays under
    ``_WOBBLE_MAX`` (beyond, the flow failed). Returns the verdict and the numbers
    (``wobble``, ``share``, ``noise``).
    """
    wobble, share, noise = vibration_level(left, right, height)
    numbers = {"wobble": round(wobble, 5), "share": round(share, 3), "noise": round(noise, 5)}
    return (share >= SHARE and wobble >= SIGNAL * noise and 0 < wobble <= _WOBBLE_MAX,
            numbers)


def detect_vibration(halves: Sequence[tuple[tuple[np.ndarray, np.ndarray], ...]], height: int,
                     probe: int) -> float | None:
    """Return the wobble (fraction of the height) if the frame pairs pass :func:`wobble_test`.

    Parameters
    ----------
    halves : list of (left, right)
        Per frame pair, in order: :func:`half_row_flows` of its flow.
    height : int
        Rows per frame.
    probe : int
        Fewer pairs than this are never said to vibrate.
    """
    if len(halves) < probe:
        return None
    passed, numbers = wobble_test([p[0] for p in halves], [p[1] for p in halves], height)
    return numbers["wobble"] if passed else None


HalfRows = tuple[np.ndarray, np.ndarray, np.ndarray]  # rows, row flows, weights
ProbePair = tuple[float, float, HalfRows, HalfRows]  # the pair's starts, left, right


def probe_pair(prev: float, cur: float, flow: np.ndarray, ok: np.ndarray) -> ProbePair:
    """Return a pair's starts and each half's rows, row flows and weights (:func:`row_flows`).

    A row's weight is the share of its pixels whose flow agrees with the row's
    (:data:`~unjello.motion.flow.dis.ROW_AGREE`), as the camera solve weighs it. The
    halves split the reliable pixels evenly (at their median column): a frame whose one
    side is blank still gives two halves to compare.
    """
    counts = np.cumsum(ok.sum(axis=0))
    half = int(np.searchsorted(counts, 0.5 * counts[-1])) if counts[-1] else flow.shape[1] // 2
    half = min(max(half, 1), flow.shape[1] - 1)
    left, right = (row_flows(flow[:, c], ok[:, c], ROW_AGREE)
                   for c in (slice(0, half), slice(half, None)))
    return prev, cur, left, right


def _half_equations(pairs: Sequence[ProbePair], side: int, height: int, readout: float
                    ) -> tuple[np.ndarray, ...]:
    """Return the row equations (eq. 10's timing) of one half of every probed pair."""
    eqs = [(cur + readout * y / height, prev + readout * (y + med[:, 1]) / height,
            y / max(height - 1, 1), -med, wgt)
           for prev, cur, *halves in pairs for y, med, wgt in (halves[side],) if len(y)]
    return tuple(np.concatenate([e[i] for e in eqs]) for i in range(5)) if eqs else ()


def _held_out(fit: tuple[np.ndarray, ...], test: tuple[np.ndarray, ...], step: float,
              smoothness: float, sinusoids: int) -> float:
    """Return the weighted mean distance (px) of ``test``'s row flows from a fit on ``fit``."""
    t_a, t_b, rows, delta, wgt = fit
    freqs = pick_frequencies(t_a, t_b, delta, wgt, sinusoids) if sinusoids else None
    sol = solve_camera_trajectory(t_a, t_b, rows, delta, wgt, step, smoothness, freqs=freqs)
    miss = np.hypot(*(test[3] - sol.differences(test[0], test[1], test[2])).T)
    return float((miss * test[4]).sum() / max(float(test[4].sum()), 1e-12))


def choose_model(pairs: Sequence[ProbePair], height: int, readout: float, step: float,
                 smoothness: float) -> tuple[bool, dict[str, float]]:
    """Choose the camera model that explains the probed frame pairs: smooth or vibrating.

    Two kinds of evidence from the footage, both needed:

    1. :func:`wobble_test`: the motion that both halves of the frame share changes within
       a frame (a mount's vibration), far above what the halves disagree on;
    2. the vibration model (:data:`VIBRATION`: a trajectory that may bend at scanline
       resolution, sinusoids of free frequency), fitted to the row flows of one half of
       the frame, predicts the other half's with at most :data:`PREFER` of the error of
       the smooth model of the default settings, each way (two-fold cross-validation),
       the smooth model's misses at least :data:`VISIBLE` px, and what the vibration
       model gains stands :data:`SIGNAL` times above the noise of the wobble test.
       Vibration moves whole rows, so a model that follows it predicts the other half;
       one that follows what one half has alone (a pole the flow followed over a flat
       sky, noise) does not.

    A flexible model predicts shake and pans from rest better too: the wobble test tells
    them apart (their wobble is a small share of their motion).

    Parameters
    ----------
    pairs : sequence of (prev_start, cur_start, left, right)
        The probed frame pairs: their frames' start times and each half's
        ``(rows, row flows, weights)`` (:func:`~unjello.motion.flow.dis.row_flows`).
    height : int
        Rows per frame.
    readout : float
        The readout, in frame intervals.
    step, smoothness : float
        The trajectory's grid step and the smooth model's penalty.

    Returns
    -------
    vibrating : bool
    evidence : dict
        ``pairs``; ``wobble``, ``share``, ``noise`` (:func:`wobble_test`); where that
        passed, ``smooth_px`` and ``vibration_px``: each model's mean error on the half
        it was not fitted on.

    Examples
    --------
    >>> h, rng = 100, np.random.default_rng(0)
    >>> def pair(k, c):  # rows of frame k - 1 -> k, the camera c(t) = (x(t), 0)
    ...     y = np.arange(h, dtype=float)
    ...     d = c(k + y / h) - c(k - 1 + y / h)
    ...     half = lambda: (y, np.stack([-(d + rng.normal(0, .02, h)), 0 * y], 1), 1 + 0 * y)
    ...     return (k - 1.0, float(k), half(), half())
    >>> jello = lambda t: 0.8 * np.sin(2 * np.pi * 1.37 * t) + 3 * t
    >>> choose_model([pair(k, jello) for k in range(1, 9)], h, 1.0, 1 / 64, 3e-3)[0]
    True
    >>> shake = lambda t: 8 * np.sin(2 * np.pi * 0.1 * t) + 3 * t
    >>> choose_model([pair(k, shake) for k in range(1, 9)], h, 1.0, 1 / 64, 3e-3)[0]
    False
    """
    evidence: dict[str, float] = {"pairs": len(pairs)}
    passed, numbers = wobble_test([p[2] for p in pairs], [p[3] for p in pairs], height)
    evidence.update(numbers)
    halves = [_half_equations(pairs, side, height, readout) for side in (0, 1)]
    if not passed or any(len(hv) == 0 or hv[0].size < 8 for hv in halves):
        return False, evidence
    errors = [0.5 * (_held_out(halves[0], halves[1], step, smooth, sines)
                     + _held_out(halves[1], halves[0], step, smooth, sines))
              for smooth, sines in ((smoothness, 0),
                                    (VIBRATION["smoothness"], VIBRATION["sinusoids"]))]
    evidence.update(smooth_px=round(errors[0], 4), vibration_px=round(errors[1], 4))
    # What the vibration model adds stands above the halves' disagreement as the wobble
    # must (a tilt behind poles over a flat sky: 0.05 px gained over 0.05 px of noise).
    gain = errors[0] - errors[1] >= SIGNAL * evidence["noise"] * height
    return errors[1] <= PREFER * errors[0] and errors[0] >= VISIBLE and gain, evidence


def _norms(cos: np.ndarray, sin: np.ndarray, ridge: float
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return the columns' products ``cos.cos + ridge``, ``sin.sin + ridge``, ``cos.sin``."""
    return (cos * cos).sum(0) + ridge, (sin * sin).sum(0) + ridge, (cos * sin).sum(0)


def _projected(cos: np.ndarray, sin: np.ndarray, resid: np.ndarray,
               norms: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
    """Return the energy of ``resid`` (m, 2) on span{cos_f, sin_f}, each f, x and y together.

    ``norms`` are :func:`_norms` of the columns (a ridge there shrinks the amplitudes).
    """
    cc, ss, cs = norms
    rc, rs = cos.T @ resid, sin.T @ resid  # (columns, axes)
    return ((ss[:, None] * rc ** 2 - 2 * cs[:, None] * rc * rs + cc[:, None] * rs ** 2)
            / (cc * ss - cs ** 2 + 1e-12)[:, None]).sum(axis=1)


def sinusoid_pursuit(t_a: np.ndarray, t_b: np.ndarray, delta: np.ndarray,
                     weight: np.ndarray, base: np.ndarray, count: int,
                     max_cycles: float = MAX_CYCLES, ridge: float = 0.0
                     ) -> tuple[np.ndarray, float]:
    """Sinusoids of a trajectory seen through its differences ``c(t_a) - c(t_b) = delta``.

    Orthogonal matching pursuit: ``count`` times, the frequency (0.01 to ``max_cycles``
    cycles per unit of time, on a 0.0025 grid, shared by x and y) whose cosine and sine
    explain most of what ``base`` and the sinusoids so far leave of ``delta``; then all
    amplitudes are refitted.

    Parameters
    ----------
    t_a, t_b : ndarray of shape (m,)
        Times of the two ends of each equation.
    delta : ndarray of shape (m, 2)
        Observed differences.
    weight : ndarray of shape (m,)
        Confidence of each equation.
    base : ndarray of shape (m, b)
        Other columns of the model (``b`` may be 0), fitted with the sinusoids.
    count : int
        Sinusoids to pick.
    max_cycles : float
        Highest frequency considered.
    ridge : float
        Penalty on the squared amplitudes, relative to the total weight, in the choice:
        a sinusoid the differences barely see (near a multiple of the frame rate) must
        not be picked to fit noise with a huge amplitude.

    Returns
    -------
    freqs : ndarray of shape (count,)
        The frequencies picked, in order.
    residual : float
        Weighted residual energy of the final fit.

    Examples
    --------
    >>> t_a = np.linspace(1, 9, 400); t_b = t_a - 1.0
    >>> c = lambda t: np.stack([np.sin(2 * np.pi * 0.77 * t), np.cos(2 * np.pi * 1.3 * t)], 1)
    >>> f, r = sinusoid_pursuit(t_a, t_b, c(t_a) - c(t_b), np.ones(400), np.zeros((400, 0)), 2)
    >>> sorted(np.round(f, 2).tolist()), bool(r < 1e-9)
    ([0.77, 1.3], True)
    """
    sw = np.sqrt(weight)[:, None]
    rhs = delta * sw
    cols = [base * sw]
    resid = rhs - cols[0] @ np.linalg.lstsq(cols[0], rhs, rcond=None)[0] if base.shape[1] else rhs
    grid = np.arange(0.01, max_cycles, 0.0025)
    pa, pb = (2 * np.pi) * t_a[:, None] * grid, (2 * np.pi) * t_b[:, None] * grid
    cos = (np.cos(pa) - np.cos(pb)) * sw
    sin = (np.sin(pa) - np.sin(pb)) * sw
    norms = _norms(cos, sin, ridge * float(weight.sum()))
    picked: list[int] = []
    for _ in range(count):
        f = int(np.argmax(_projected(cos, sin, resid, norms)))
        picked.append(f)
        cols.append(np.stack([cos[:, f], sin[:, f]], axis=1))
        a = np.concatenate(cols, axis=1)
        resid = rhs - a @ np.linalg.lstsq(a, rhs, rcond=None)[0]
    return grid[picked], float((resid ** 2).sum())


def pick_frequencies(t_a: np.ndarray, t_b: np.ndarray, delta: np.ndarray, weight: np.ndarray,
                     count: int) -> np.ndarray:
    """Return the frequencies of a vibration seen through row equations ``c(t_a) - c(t_b)``.

    :func:`sinusoid_pursuit` on the equations themselves, with only a cubic drift beside
    the sinusoids. Near a multiple of the frame rate a vibration shows in the frame
    pairs as a slow change from pair to pair, which a flexible smooth trajectory takes
    for its own: picked from what such a trajectory left, 5 of the matrix's 34 jello
    cases lost a vibration within 0.05 cycles of a multiple to its aliases or to
    sinusoids beside it (``docs/matrix.md``).

    Parameters
    ----------
    t_a, t_b : ndarray of shape (m,)
        Times of the two ends of each equation (frame intervals).
    delta : ndarray of shape (m, 2)
        Observed differences.
    weight : ndarray of shape (m,)
        Confidence of each equation.
    count : int
        Sinusoids to pick.

    Returns
    -------
    ndarray of shape (count,)
        Cycles per frame interval, in the order picked.

    Examples
    --------
    A wobble of 2.97 cycles a frame interval (0.19 of it visible in a frame pair) on a
    slow pan:

    >>> t_a = (np.arange(1, 33)[:, None] + 0.9 * np.linspace(0, 1, 40)).ravel()
    >>> t_b = t_a - 1.0
    >>> c = lambda t: np.stack([2 * t + 0.01 * t ** 2 + 4 * np.sin(2 * np.pi * 2.97 * t),
    ...                         np.zeros_like(t)], axis=1)
    >>> round(float(pick_frequencies(t_a, t_b, c(t_a) - c(t_b), np.ones(t_a.size), 1)[0]), 4)
    2.97

    Closer to the multiple, :data:`SINE_RIDGE` pulls the pursuit's pick away from it
    (2.99 was picked as 2.985); :func:`refine_frequencies` takes it back:

    >>> c = lambda t: np.stack([2 * t + 0.01 * t ** 2 + 4 * np.sin(2 * np.pi * 2.99 * t),
    ...                         np.zeros_like(t)], axis=1)
    >>> round(float(pick_frequencies(t_a, t_b, c(t_a) - c(t_b), np.ones(t_a.size), 1)[0]), 4)
    2.99
    """
    mid = 0.5 * (min(float(t_a.min()), float(t_b.min())) + max(float(t_a.max()),
                                                                float(t_b.max())))
    ta, tb = t_a - mid, t_b - mid
    drift = np.stack([ta - tb, ta ** 2 - tb ** 2, ta ** 3 - tb ** 3], axis=1)
    freqs = sinusoid_pursuit(ta, tb, delta, weight, drift, count, ridge=SINE_RIDGE)[0]
    return refine_frequencies(ta, tb, delta, weight, drift, freqs)


def refine_frequencies(t_a: np.ndarray, t_b: np.ndarray, delta: np.ndarray,
                       weight: np.ndarray, base: np.ndarray, freqs: np.ndarray,
                       reach: float = REFINE_REACH, step: float = REFINE_STEP,
                       rounds: int = REFINE_ROUNDS) -> np.ndarray:
    """Move each frequency to where it explains the most, the others held (no ridge).

    Each in turn, ``rounds`` times: the frequency within ``reach`` of it, on a grid of
    ``step``, whose cosine and sine explain most of what ``base`` and the other
    sinusoids leave of ``delta`` (least squares, x and y together). The pursuit's grid
    and its ridge leave a pick up to :data:`REFINE_REACH` off, and a frequency off by
    0.00125 is a quarter-radian off 30 frames away.

    Parameters
    ----------
    t_a, t_b, delta, weight, base :
        As for :func:`sinusoid_pursuit`.
    freqs : ndarray of shape (k,)
        The frequencies picked.
    reach, step : float
        How far each may move, and the grid it moves on.
    rounds : int
        Passes over all of them.

    Returns
    -------
    ndarray of shape (k,)

    Examples
    --------
    >>> t_a = (np.arange(1, 33)[:, None] + np.linspace(0, 1, 40)).ravel(); t_b = t_a - 1
    >>> c = lambda t: np.stack([np.sin(2 * np.pi * 1.3012 * t), 0 * t], axis=1)
    >>> f = refine_frequencies(t_a, t_b, c(t_a) - c(t_b), np.ones(t_a.size),
    ...                        np.zeros((t_a.size, 0)), np.array([1.3]))
    >>> round(float(f[0]), 5)
    1.301
    """
    sw = np.sqrt(weight)[:, None]
    rhs = delta * sw

    def columns(f: np.ndarray) -> np.ndarray:  # (m, 2 len(f)): the cosines, then the sines
        pa, pb = 2 * np.pi * t_a[:, None] * f, 2 * np.pi * t_b[:, None] * f
        return np.concatenate([np.cos(pa) - np.cos(pb), np.sin(pa) - np.sin(pb)], axis=1) * sw

    out = np.array(freqs, dtype=np.float64)
    offsets = np.arange(-reach, reach + step / 2, step)
    n = offsets.size
    for _ in range(rounds):
        for j in range(out.size):
            q = np.linalg.qr(np.concatenate([base * sw, columns(np.delete(out, j))], axis=1))[0]
            left = rhs - q @ (q.T @ rhs)
            cand = columns(out[j] + offsets)
            cand -= q @ (q.T @ cand)  # what the others cannot explain
            cos, sin = cand[:, :n], cand[:, n:]
            gain = _projected(cos, sin, left, _norms(cos, sin, 0.0))
            out[j] += offsets[int(np.argmax(gain))]
    return out
