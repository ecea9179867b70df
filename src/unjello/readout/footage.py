"""The readout time estimated from the footage itself: its motion and its straight lines.

The readout ratio ``rho`` sets when each row is imaged (``t_n + rho y / h``). Between
two frames, row ``y``'s content moved from row ``y'`` of the previous frame, so the
per-row flow is a difference of the camera trajectory at two times that depend on
``rho`` (eq. 10 with ``rho``): ``c(t_a) - c(t_b) = -f``. Under the true ``rho`` all rows
of all frame pairs are explained by one trajectory; under a wrong one the equations
contradict each other wherever the motion changes. :func:`estimate_readout` scores
each candidate by the cost of that fit (the per-row flows being computed once), with
one of two trajectory models:

- **smooth** (pans, stops, hand shake): a trajectory sampled finely in time with a
  small penalty on its acceleration (regularised least squares,
  :func:`unjello.motion.dense.camera.solve_camera_trajectory`), four frame pairs at a time.
- **vibration** (when the rows wobble as :func:`unjello.motion.dense.vibration.vibration_level`
  detects it): rows only sample the readout part of each frame interval, so ``rho``
  shows only in how the trajectory continues across the blanking, and a smoothness
  penalty prefers the candidate that stretches a fast vibration most (long readouts).
  Here the trajectory of twelve frame pairs is a quadratic drift plus six sinusoids of
  any frequency up to 1.6 cycles per frame interval, chosen greedily (orthogonal
  matching pursuit on a fine frequency grid, shared by x and y): the same number of
  parameters for every candidate (:func:`_spectral_cost`). Vibration above the frame
  rate aliases between frames, but each frame's rows see it unaliased, so only the true
  ``rho`` lines both up.

A constant velocity gives every ``rho`` the same cost -- the skew is the same in every
frame, so no method can tell -- and the estimate then falls back to a default with a
low confidence.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Iterable
from dataclasses import dataclass

import cv2
import numpy as np

from ..lens import Lens
from ..timing import to_top_bottom
from .lines import CONFIDENT, LineCue, confidence_of, line_readout
from .rotation import WINDOW, cell_flows, describe_lens, fit_rotation, parabola_minimum

__all__ = ["MOTION_SIGMA", "ROTATION_EXPLAINS", "ROTATION_SIGMA", "ReadoutEstimate",
           "estimate_readout", "estimate_readout_file", "pool_estimates", "estimate_clips",
           "readout_preset", "lens_flags"]


#: The translation trajectory's acceleration penalty, its reweighting rounds, the vibration
#: model's sinusoids and their top frequency (cycles a frame; ``docs/tuning.md#readout-estimate``).
_SMOOTHNESS = 1e-4
_SINUSOIDS = 6
_ROBUST = 3
_MAX_CYCLES = 1.6


def _spectral_cost(t_a: np.ndarray, t_b: np.ndarray, delta: np.ndarray, weight: np.ndarray
                   ) -> float:
    """Residual of ``c(t_a) - c(t_b) = delta`` with ``c`` = quadratic drift + sinusoids.

    The sinusoids (:data:`_SINUSOIDS`, up to :data:`_MAX_CYCLES` per frame interval) are
    picked by :func:`unjello.motion.dense.method.sinusoid_pursuit`.

    Examples
    --------
    A 31 Hz vibration at 30 fps read in 0.6 of the frame interval: the true readout
    explains the rows best.

    >>> y = np.tile(np.linspace(0, 1, 200), 8)
    >>> def times(rho):
    ...     t_a = np.repeat(np.arange(1.0, 9.0), 200) + rho * y
    ...     return t_a, t_a - 1
    >>> c = lambda t: np.stack([np.sin(2 * np.pi * 31 / 30 * t), 0 * t], axis=1)
    >>> ta, tb = times(0.6)
    >>> d, w = c(ta) - c(tb), np.ones(ta.size)
    >>> costs = {rho: _spectral_cost(*times(rho), d, w) for rho in (0.4, 0.5, 0.6, 0.7, 0.8)}
    >>> min(costs, key=costs.get)
    0.6
    """
    from ..motion.dense.vibration import sinusoid_pursuit

    t0 = 0.5 * (min(float(t_a.min()), float(t_b.min())) + max(float(t_a.max()),
                                                              float(t_b.max())))
    ta, tb = t_a - t0, t_b - t0
    drift = np.stack([ta - tb, ta ** 2 - tb ** 2], axis=1)
    return sinusoid_pursuit(ta, tb, delta, weight, drift, _SINUSOIDS, _MAX_CYCLES)[1]


#: The vibration model's estimate needs this confidence: drone jello 0.81-0.95, a rolled
#: street's poles wobbling 0.56-0.65 (``docs/tuning.md#_vibration_confidence``).
_VIBRATION_CONFIDENCE = 0.7

#: The shortest readout an estimate reports (a fraction of the frame interval).
_SHORTEST = 0.05
#: A cue's best guess further outside (0, 1] than this many of its uncertainties is wrong, not
#: uncertain, and is not pooled (the lines' -0.52 +-0.14 on a deep room, TUM RS-VI seq. 9).
_OUTSIDE = 2.0

#: The rotation model's estimate is reliable where its uncertainty (at least
#: :data:`MOTION_SIGMA`) is within this (``docs/readout.md``, "A camera that turns") ...
ROTATION_SIGMA = 0.05
#: ... and it explains this share of the cells' motion (TUM's sequence 4 0.998; the phone
#: in a moving car 0.86, its guess 0.4 short of the stated 1.0).
ROTATION_EXPLAINS = 0.98

#: The uncertainty (one sigma, of the frame interval) of a reliable motion estimate: the
#: simulated clips of ``benchmarks/readout.py`` are within 0.015 where it says it is reliable.
MOTION_SIGMA = 0.02


@dataclass(frozen=True)
class ReadoutEstimate:
    """Readout ratio estimated from footage.

    Attributes
    ----------
    readout : float
        The estimate (or the fallback), fraction of the frame interval.
    confidence : float
        0-1: for the motion cue, how much better the best candidate explains the motion
        than the others; for the lines, :func:`~unjello.readout.lines.confidence_of` of
        their uncertainty. 0.5 and more is reliable.
    reliable : bool
        False when the footage cannot tell and ``readout`` is the fallback.
    candidates : ndarray of shape (k,)
    costs : ndarray of shape (k,)
        The motion fit's cost of each candidate (lower is better).
    model : {'smooth', 'vibration'}
        The trajectory model the candidates were scored with.
    cue : str
        What the estimate rests on: ``motion``, ``lines``, ``pooled`` or ``none``.
    uncertainty : float
        One standard deviation of the estimate (``inf`` when the footage cannot tell).
    best_guess : float
        The estimate even where it is not reliable (NaN with no evidence at all): what
        :func:`pool_estimates` weighs by its uncertainty.
    note : str
        What the straight lines said of a motion estimate (they agree or disagree).
    lines_agree : bool, optional
        Where the motion estimate stands and the straight lines were confident: whether
        they agree with it (within three combined standard deviations); None otherwise.
    lens : Lens, optional
        The lens the rotation model fitted (or was given), where that model was used.
    explained : float
        The rotation model's share of the motion explained (NaN where not used): below
        :data:`ROTATION_EXPLAINS` its estimate is not trusted.
    """

    readout: float
    confidence: float
    reliable: bool
    candidates: np.ndarray
    costs: np.ndarray
    model: str = "smooth"
    cue: str = "motion"
    uncertainty: float = float("inf")
    best_guess: float = float("nan")
    note: str = ""
    lines_agree: bool | None = None
    lens: Lens | None = None
    explained: float = float("nan")

    def describe(self) -> str:
        """One line: the readout and what it rests on, or why it is unknown."""
        if not self.reliable:
            why = self.note or ("neither its motion nor its straight lines change enough to "
                                "tell (a steady pan, two frames, a still or flat view)")
            return (f"readout unknown: {why} (confidence {self.confidence:.2f}; "
                    f"{self.readout:g}, the whole frame interval, unless told otherwise)"
                    if self.readout == 1.0 else
                    f"readout unknown: {why} (confidence {self.confidence:.2f}; "
                    f"{self.readout:g} unless told otherwise)")
        rest = {"motion": f"{self.model} motion model", "lines": "the lean of straight lines",
                "pooled": "clips pooled"}.get(self.cue, self.cue)
        if self.cue == "motion" and self.model == "rotation" and self.lens is not None:
            rest += f" through {describe_lens(self.lens)}"
        if self.note:
            rest += f"; {self.note}"
        return (f"readout {self.readout:.3f} of the frame interval "
                f"(+-{self.uncertainty:.3f}, confidence {self.confidence:.2f}, {rest})")

    def as_json(self, costs: bool = True) -> dict:
        """Return the estimate as plain JSON types (with the candidates' costs, or without)."""
        def num(v: float) -> float | None:
            return float(v) if np.isfinite(v) else None
        out = {"readout": self.readout, "confidence": self.confidence,
               "reliable": self.reliable, "cue": self.cue, "model": self.model,
               "uncertainty": num(self.uncertainty), "best_guess": num(self.best_guess),
               "note": self.note, "lines_agree": self.lines_agree,
               "explained": num(self.explained),
               "lens": None if self.lens is None else {
                   "focal": self.lens.focal,
                   "distortion": None if self.lens.k is None else list(self.lens.k)}}
        if costs:
            out.update(candidates=self.candidates.tolist(), costs=self.costs.tolist())
        return out


def _combine(motion: ReadoutEstimate, lines: LineCue, fallback: float) -> ReadoutEstimate:
    """Combine the motion cue and the lines': the motion first, the lines where it cannot tell.

    Where the motion can tell, its estimate stands and the lines check it (said in the
    note): averaged in, the lines' estimate made stops and starts over curved edges
    worse in ``benchmarks/readout.py`` (a velocity that jumps within a frame, edges that
    are not straight mislead them more than their scatter shows). Where it cannot, a
    confident lines' estimate is the estimate; else the best guess of either, with its
    uncertainty, is kept for pooling (:func:`pool_estimates`).
    """
    if motion.reliable:
        note, agree = "", None
        if lines.confident:
            agree = bool(abs(motion.readout - lines.readout)
                         <= 3.0 * np.hypot(motion.uncertainty, lines.uncertainty))
            note = (f"the straight lines {'agree' if agree else 'disagree'}: "
                    f"{lines.readout:.3f} (+-{lines.uncertainty:.3f})")
        return dataclasses.replace(motion, cue="motion", best_guess=motion.readout, note=note,
                                   lines_agree=agree)
    if lines.confident:
        return dataclasses.replace(
            motion, readout=_inside(lines.readout),
            confidence=confidence_of(lines.uncertainty), reliable=True, cue="lines",
            uncertainty=lines.uncertainty, best_guess=_inside(lines.readout))
    # Neither can tell: the two best guesses by their uncertainties, for pooling.
    guesses = [(g, u) for g, u in ((motion.best_guess, motion.uncertainty),
                                   (lines.readout, lines.uncertainty))
               if np.isfinite(g) and np.isfinite(u) and u > 0
               and _SHORTEST - _OUTSIDE * u <= g <= 1.0 + _OUTSIDE * u]
    guess, sigma = float("nan"), float("inf")
    if guesses:
        wts = np.array([1.0 / u ** 2 for _, u in guesses])
        guess = float(np.sum(wts * [g for g, _ in guesses]) / wts.sum())
        sigma = float(1.0 / np.sqrt(wts.sum()))
    return dataclasses.replace(motion, readout=fallback, reliable=False, cue="none",
                               uncertainty=sigma, best_guess=_inside(guess))


def _inside(readout: float) -> float:
    """Keep a best guess inside (0, 1]: :data:`_SHORTEST` to the whole frame interval."""
    return float(np.clip(readout, _SHORTEST, 1.0)) if np.isfinite(readout) else readout


def pool_estimates(estimates: Iterable[ReadoutEstimate], fallback: float = 1.0
                   ) -> ReadoutEstimate:
    """Pool the estimates of several clips of one camera mode (its readout is fixed).

    Each clip's best guess counts by its uncertainty (inverse variance). Where the
    clips disagree more than their uncertainties allow (a reduced chi-square above 1),
    the pooled uncertainty is widened by its square root (the Birge ratio). The pool is
    reliable within the bound of its clips' model (:data:`ROTATION_SIGMA` where one is a
    turning camera's, else the lines' ``CONFIDENT``), and carries their model where they
    share one.
    """
    est = [e for e in estimates if np.isfinite(e.uncertainty) and np.isfinite(e.best_guess)]
    empty = np.zeros(0)
    if not est:
        return ReadoutEstimate(fallback, 0.0, False, empty, empty, cue="none")
    r = np.array([e.best_guess for e in est])
    w = np.array([1.0 / e.uncertainty ** 2 for e in est])
    mean = float(np.sum(w * r) / w.sum())
    sigma = float(1.0 / np.sqrt(w.sum()))
    if len(est) > 1:
        chi2 = float(np.sum(w * (r - mean) ** 2) / (len(est) - 1))
        sigma *= max(1.0, np.sqrt(chi2))
    # Estimates of a turning camera are trusted to ROTATION_SIGMA, the others' to CONFIDENT.
    models = {e.model for e in est}
    bound = ROTATION_SIGMA if "rotation" in models else CONFIDENT
    reliable = sigma <= bound
    return ReadoutEstimate(_inside(mean) if reliable else fallback,
                           float(1.0 / (1.0 + (sigma / bound) ** 2)), bool(reliable), empty,
                           empty, models.pop() if len(models) == 1 else "smooth",
                           cue="pooled" if reliable else "none", uncertainty=sigma,
                           best_guess=_inside(mean))


def estimate_readout(frames: Iterable[np.ndarray], *, direction: str = "top-bottom",
                     starts: Iterable[float] | None = None, max_frames: int = 60,
                     fallback: float = 1.0, min_confidence: float = 0.5,
                     min_variation: float = 0.5, lines: bool = True,
                     motion: bool = True, lens: Lens | None = None) -> ReadoutEstimate:
    """Estimate the readout ratio from a clip (see the module notes).

    Parameters
    ----------
    frames : iterable of ndarray of shape (H, W[, C])
        Consecutive frames in coded orientation (only the first ``max_frames`` are used).
    direction : str
        Scan direction.
    starts : iterable of float, optional
        Frame start times in frame intervals (default 0, 1, 2, ...).
    max_frames : int
        Frames to analyse.
    fallback : float
        Readout returned when the motion cannot tell.
    min_confidence : float
        Below this confidence the estimate is not reliable and ``fallback`` is returned.
        Set between what hand shake and pan-then-stop score (0.56 and more on the
        simulated clips of ``benchmarks/readout.py``) and what vibration near the frame
        rate scores (0.40 and less), whose estimates are biased.
    min_variation : float
        Standard deviation (px) the per-row flows must show over rows and frames; less
        is uniform motion, from which the readout cannot be told (confidence 0).
    lines : bool
        Also read the lean of straight lines (:func:`~unjello.readout.lines.line_readout`)
        and combine the two cues (:func:`_combine`).
    motion : bool
        Use the motion model (False: the straight lines alone).
    lens : Lens, optional
        The camera's lens (of the frames in top-to-bottom orientation), where known; else
        the rotation model fits one (:func:`~unjello.readout.rotation.fit_rotation`).

    Returns
    -------
    ReadoutEstimate
    """
    from ..motion.dense.camera import solve_camera_trajectory
    from ..motion.dense.method import DenseConfig
    from ..motion.dense.vibration import detect_vibration
    from ..motion.flow.dis import FlowSettings, flow_pair, half_row_flows, row_flows

    grey, times = [], []
    start_list = list(starts) if starts is not None else None
    for i, img in enumerate(frames):
        if i >= max_frames:
            break
        g = to_top_bottom(np.asarray(img), direction)
        if g.ndim == 3:
            g = cv2.cvtColor(g[..., :3].astype(np.float32), cv2.COLOR_RGB2GRAY)
        grey.append(g.astype(np.float32) * (255.0 / max(float(g.max()), 1.0)
                                            if g.dtype != np.uint8 else 1.0))
        times.append(float(start_list[i]) if start_list is not None else float(i))
    empty = np.zeros(0)
    if len(grey) < 2:
        return ReadoutEstimate(fallback, 0.0, False, empty, empty, cue="none")
    h = grey[0].shape[0]
    # Flow at DIS medium's own finest level (half resolution) on copies up to 640 px
    # wide: the confidence threshold was calibrated with it; at full resolution
    # pan-then-stop scored as low as 0.52. (Its flow settings are kept as calibrated.)
    flow = FlowSettings("medium", finest_scale=1, refinement=None, consistency=10.0)
    pairs, halves, ahead, cells = [], [], [], []
    for k in range(1, len(grey)):
        bwd, ok, fwd, _ = flow_pair(grey[k - 1], grey[k], flow, 640, two_way=True)
        pairs.append(row_flows(bwd, ok))
        cells.append(cell_flows(bwd, ok))
        halves.append(half_row_flows(bwd, ok))
        ahead.append(fwd)
    line_cue = (line_readout(grey, np.asarray(times), ahead) if lines
                else LineCue(float("nan"), float("inf"), "none"))
    if len(grey) < 3 or not motion:  # two frames: no motion model, the lines alone
        none = ReadoutEstimate(fallback, 0.0, False, empty, empty, cue="none")
        return _combine(none, line_cue, fallback)
    # Vibration is told as the dense method's --vibration auto tells it (as many pairs).
    vibrating = detect_vibration(halves, h, DenseConfig().probe) is not None
    window = 12 if vibrating else 4
    # Uniform motion carries no information on the readout: check there is variation.
    flows = np.concatenate([p[1] for p in pairs if p[1].size]) if any(
        p[1].size for p in pairs) else np.zeros((0, 2))
    variation = float(np.linalg.norm(flows.std(axis=0))) if len(flows) > 1 else 0.0
    if vibrating:
        # The vibration model's cost grows with the equations: about 120 rows per pair
        # are plenty (a 1.6-cycle vibration spans at most 1.6 periods of the rows).
        step = max(1, h // 120)
        pairs = [(y[::step], med[::step], wgt[::step]) for y, med, wgt in pairs]
    # The vibration model's windows overlap by half and all hold twelve pairs.
    last = max(1, len(pairs) - window // 2) if vibrating else len(pairs)
    candidates = np.round(np.arange(0.1, 1.0001, 0.05), 4)
    costs = np.zeros(candidates.size)
    for j, rho in enumerate(candidates):
        total = 0.0
        for k0 in range(0, last, window // 2):
            eq = []
            for k in range(k0, min(k0 + window, len(pairs))):
                y, med, wgt = pairs[k]
                if y.size == 0:
                    continue
                t_a = times[k + 1] + rho * y / h
                t_b = times[k] + rho * (y + med[:, 1]) / h
                eq.append((t_a, t_b, -med, wgt))
            if not eq:
                continue
            t_a, t_b, delta, wgt = (np.concatenate([e[i] for e in eq]) for i in range(4))
            total += _spectral_cost(t_a, t_b, delta, wgt) if vibrating else (
                solve_camera_trajectory(t_a, t_b, None, delta, wgt, 1.0 / 32,
                                        _SMOOTHNESS, robust=_ROBUST).cost)
        costs[j] = total
    best = int(np.argmin(costs))
    rho = parabola_minimum(candidates, costs)
    spread = float(np.median(costs) - costs[best])
    confidence = float(np.clip(spread / (np.median(costs) + 1e-12), 0.0, 1.0))
    if variation < min_variation:
        confidence = 0.0
    reliable = confidence >= (max(min_confidence, _VIBRATION_CONFIDENCE) if vibrating
                              else min_confidence)
    if best == 0:  # no minimum inside the candidates: the cost falls on beyond them
        reliable = False
    from_motion = ReadoutEstimate(_inside(rho) if reliable else fallback,
                                  confidence, reliable, candidates, costs,
                                  "vibration" if vibrating else "smooth",
                                  uncertainty=MOTION_SIGMA if reliable else float("inf"),
                                  best_guess=rho if reliable else float("nan"))
    if vibrating:  # a wobble within the frame bends lines: their lean says nothing clear
        line_cue = LineCue(float("nan"), float("inf"), "none")
    elif variation >= min_variation and len(cells) >= 2 * WINDOW:
        from_motion = _turning(cells, np.asarray(times), grey[0].shape, lens, fallback,
                               from_motion)
    return _combine(from_motion, line_cue, fallback)


def _turning(cells: list, times: np.ndarray, size: tuple[int, int], lens: Lens | None,
             fallback: float, translation: ReadoutEstimate) -> ReadoutEstimate:
    """Return the rotation model's estimate where a turning camera explains the flow best.

    :func:`~unjello.readout.rotation.fit_rotation` fits the lens (unless given) and the
    readout; where its lens is no better than the longest focal length (a translation),
    the translation model's estimate ``translation`` stands.
    """
    fit = fit_rotation(cells, times, size, lens)
    if not fit.turning:
        return translation
    # Motion the rotation does not explain (travel, traffic) biases the readout more
    # than the windows' scatter shows: there a window's scatter is the uncertainty.
    explains = fit.explained >= ROTATION_EXPLAINS
    sigma = max(fit.uncertainty if explains else fit.spread, MOTION_SIGMA)
    reliable = bool(explains and sigma <= ROTATION_SIGMA
                    and _SHORTEST <= fit.readout <= 1.0 + sigma)
    guess = _inside(fit.readout) if np.isfinite(sigma) else float("nan")
    note = "" if reliable else (
        f"a turning camera explains {100 * fit.explained:.0f}% of its motion (travel, "
        f"traffic, parallax), too little to trust its readout ({guess:.2f} +-{sigma:.2f})"
        if not explains else
        f"the turning camera's readout rides on a focal length its motion does not pin "
        f"down ({guess:.2f} +-{sigma:.2f}, +-{fit.lens_share:.2f} from the lens fitted: "
        "give --focal)"
        if 2 * fit.lens_share ** 2 > fit.uncertainty ** 2 else  # the lens's share is the larger
        f"the turning camera's readout varies too much over the clip ({guess:.2f} "
        f"+-{sigma:.2f})")
    confidence = float(1.0 / (1.0 + (sigma / ROTATION_SIGMA) ** 2)) if explains else 0.0
    return ReadoutEstimate(guess if reliable else fallback, confidence, reliable,
                           fit.candidates, fit.costs, "rotation", uncertainty=sigma,
                           best_guess=guess, note=note, lens=fit.lens,
                           explained=fit.explained)


def estimate_readout_file(src: str | os.PathLike, *, direction: str = "top-bottom",
                          max_frames: int = 60, fallback: float = 1.0,
                          fps: float | None = None, lens: Lens | None = None
                          ) -> ReadoutEstimate:
    """Estimate the readout ratio of a video or image folder from its motion.

    Parameters
    ----------
    src : path-like
        Video file or folder of frames.
    direction : str
        Scan direction.
    max_frames : int
        Frames analysed from the start.
    fallback : float
        Readout returned when the motion cannot tell.
    fps : float, optional
        The frame rate whose interval is the unit (default the video's own).
    lens : Lens, optional
        The camera's lens where known (else the rotation model fits one).

    Returns
    -------
    ReadoutEstimate
        See :func:`estimate_readout`.
    """
    from ..io.source import FrameSource

    frames: list[np.ndarray] = []
    starts: list[float] = []
    with FrameSource(src) as source:
        for pic in source.pictures(fps, limit=max_frames):
            img = pic.planes[0]
            if source.info.is_video and source.info.max_value > 255:
                img = (img >> 2).astype(np.uint8)
            frames.append(img)
            starts.append(pic.start)
    return estimate_readout(frames, direction=direction, starts=starts, fallback=fallback,
                            max_frames=max_frames, lens=lens)


def estimate_clips(paths: Iterable[str | os.PathLike], *, direction: str = "top-bottom",
                   max_frames: int = 60, lens: Lens | None = None
                   ) -> tuple[list[tuple[str, float | None, ReadoutEstimate]], ReadoutEstimate]:
    """Estimate the readout of each clip of one camera mode, and pool them.

    ``lens``: the camera's lens where known (else the rotation model fits one per clip).

    Returns
    -------
    rows : list of (path, fps, ReadoutEstimate)
        Each clip's estimate (``fps`` None for a folder).
    best : ReadoutEstimate
        The clips pooled (:func:`pool_estimates`), or the one clip's estimate.

    Raises
    ------
    SettingsError
        Standard input (it is read twice), or clips of different frame rates (a camera
        mode has one; the readout's fraction of a frame interval is pooled at it).
    """
    from ..errors import SettingsError
    from ..io.source import FrameSource

    rows = []
    for path in paths:
        if str(path) == "-":
            raise SettingsError("estimating the readout reads each clip twice: give files")
        with FrameSource(path) as source:
            fps = source.info.fps
        rows.append((str(path), fps, estimate_readout_file(path, direction=direction,
                                                           max_frames=max_frames, lens=lens)))
    rates = sorted({round(fps, 3) for _, fps, _ in rows if fps})
    if len(rates) > 1:
        raise SettingsError(f"the clips' frame rates differ ({', '.join(map(str, rates))} fps): "
                            "pool the clips of one camera mode, at one rate")
    best = pool_estimates(e for _, _, e in rows) if len(rows) > 1 else rows[0][2]
    return rows, best


def readout_preset(est: ReadoutEstimate, direction: str, fps: float | None) -> dict:
    """Return a preset (``correct --preset FILE``) of an estimated readout: ms at a known rate.

    A lens the rotation model fitted comes with it (``focal``, and a fisheye's
    ``distortion``, which ``--undistort`` needs).
    """
    value: float | str = f"{est.readout * 1000.0 / fps:.3f}ms" if fps else round(est.readout, 4)
    out: dict = {"readout": value, "direction": direction}
    if est.lens is not None and est.cue == "motion":
        out["focal"] = round(est.lens.focal, 1)
        if est.lens.k is not None:
            out["distortion"] = ",".join(f"{v:.4g}" for v in est.lens.k)
    return out


def lens_flags(lens: Lens) -> str:
    """Return the ``correct`` flags that give a fitted lens (and undistort a fisheye)."""
    if lens.k is None:
        return f"--focal {lens.focal:.0f} (a pinhole: nothing to undistort)"
    return (f"--undistort --focal {lens.focal:.0f} --distortion "
            + ",".join(f"{v:.4g}" for v in lens.k))
