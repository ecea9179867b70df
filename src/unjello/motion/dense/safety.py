"""The dense method's do-no-harm stage: no fold or tear of the per-pixel map it can avoid.

Where the per-pixel field folds or tears in blobs, or the flow failed on an object that
moves on its own, the dense method gives the region the motion around it
(:func:`~unjello.motion.objects.folds.keep_whole`) or turns a spinning object back by a
rotation fitted per scanline (:func:`~unjello.motion.objects.spinners.keep_spinning`); an object
the flow follows to every neighbour (parallax,
:func:`~unjello.motion.objects.folds.followed_objects`)
keeps its own motion. :class:`SafeField` holds these steps for
:class:`~unjello.motion.dense.method.DenseMethod`, which keeps the frames, the timing and what
the frame before kept or spun.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import cv2
import numpy as np

from ..flow.dis import FlowSettings, landing, misses
from ..objects import rigid
from ..objects.folds import (
    failed_blobs,
    fold_blobs,
    fold_share,
    followed_objects,
    keep_whole,
    unlike_neighbours,
)
from ..objects.spinners import keep_spinning

if TYPE_CHECKING:
    from collections import deque

    from ...timing import SensorTiming

__all__ = ["FOLD_WARNING", "DETAIL", "KEEP_WHOLE", "KEEP_ISLAND", "DenseFrame", "SafeField"]

#: A frame whose map folds or tears in blobs over more than this share of its pixels is reported.
#: (``docs/tuning.md#fold_warning``)
FOLD_WARNING = 0.002

#: Folds over more than KEEP_WHOLE of a frame get the motion around them, whole objects
#: (:func:`keep_whole`); above KEEP_ISLAND islands only (``docs/tuning.md#keep_whole``).
KEEP_WHOLE, KEEP_ISLAND = 0.002, 0.0016

#: Grey-level range of a 5 x 5 window below which it shows no detail: a fold over flat sky
#: draws nothing and is not reported (:func:`_on_detail`; ``docs/tuning.md#detail``).
DETAIL = 10.0

#: A neighbour whose flow carries a pixel this far (px, working copy) outside the frame does
#: not see it and cannot say the flow missed it (:meth:`SafeField._missed`).
BEYOND = 4.0


@dataclass
class DenseFrame:
    """A frame the dense method holds: its grey working copy and its flows to either side."""

    index: int
    start: float
    image: np.ndarray
    bwd: np.ndarray | None = None  # flow to the previous frame
    fwd: np.ndarray | None = None  # flow to the next frame
    bwd_ok: np.ndarray | None = None
    fwd_ok: np.ndarray | None = None
    settings: FlowSettings | None = None  # of the flow to the previous frame
    pace: np.ndarray | None = None  # its flow to the previous frame's translation a frame

    @property
    def contrast(self) -> float:
        """Standard deviation of the grey levels (a fade from black starts near 0)."""
        return float(cv2.meanStdDev(self.image)[1][0, 0])


def _beyond(flow: np.ndarray) -> np.ndarray:
    """Pixels whose flow lands more than :data:`BEYOND` px outside the frame."""
    h, w = flow.shape[:2]
    gx, gy, _ = landing(flow)
    return (gx < -BEYOND) | (gx > w - 1 + BEYOND) | (gy < -BEYOND) | (gy > h - 1 + BEYOND)


class SafeField:
    """The do-no-harm steps of :class:`~unjello.motion.dense.method.DenseMethod` (a mixin).

    It reads the method's ``timing`` and ``_frames`` and keeps, from frame to frame,
    the regions kept whole (``_kept``) and the rotations fitted (``_spins``).
    """

    timing: SensorTiming
    _frames: deque[DenseFrame]
    _kept: np.ndarray | None
    _spins: list[tuple[np.ndarray, float, float]]

    def _safe_field(self, fr: DenseFrame, field: np.ndarray, camera: np.ndarray,
                    fallback: np.ndarray, entering: np.ndarray, t_ref: float,
                    c_at: Callable[[np.ndarray], np.ndarray], u_mean: np.ndarray
                    ) -> tuple[np.ndarray, float, float, float, str, tuple[np.ndarray, ...],
                               tuple[str, ...]]:
        """Make the per-pixel field safe: no fold or tear it can avoid.

        Where the field folds in blobs, the region gets the motion around it
        (:func:`~unjello.motion.objects.folds.keep_whole`, if that folds less; ``camera``: each
        scanline's whole camera motion, eq. 26 with the rows' velocity); such regions and
        the objects whose flow failed (:func:`~unjello.motion.objects.folds.failed_blobs`) are
        tried as spinning objects (:meth:`_turn_back_spinning`). Returns the field, its
        folds, the share kept whole, the share spun, what to say, the spinning
        objects' layers in front of the field and the events
        (:data:`~unjello.trajectory.EVENTS`).
        """
        h, w = field.shape[:2]
        notes = []
        events: tuple[str, ...] = ()
        folds, kept = fold_share(field), 0.0
        regions = np.zeros((h, w), bool)
        carried, self._kept = self._kept, None
        missed = changing = followed = None
        if folds > KEEP_ISLAND or carried is not None:
            # Folds along an object that moves on its own and that the flow follows do
            # not count: they are where it covers what is behind it (parallax).
            missed, changing = self._missed(fr), self._changing(fr, c_at)
            followed = followed_objects(changing, missed)
            if followed is not None:
                changing &= ~followed
                folds = fold_share(field, followed)
        if folds > KEEP_ISLAND or carried is not None:
            # A frame that folds, or one after a frame that kept objects whole: an object
            # whose flow failed then and fails now is kept whole again (a spinning
            # object keeps spinning), even where this frame's map barely folds. One the
            # flow follows keeps its own motion.
            whole, share, after, regions = keep_whole(
                field, camera, fallback,
                changing=changing, islands_only=folds <= KEEP_WHOLE, carried=carried,
                from_folds=folds > KEEP_ISLAND, followed=followed)
            if share > 0 and (after < folds or (carried is not None and after <= folds)):
                folds_before = folds
                field, folds, kept = whole, after, share
                self._kept = regions
                why = ("the per-pixel motion folded or tore" if folds_before > KEEP_ISLAND
                       else "its object's motion failed in the frame before too")
                notes.append(f"{100 * kept:.0f}% given the motion around it ({why})")
                events += ("kept-folds" if folds_before > KEEP_ISLAND else "kept-before",)
            else:
                regions = np.zeros((h, w), bool)
        failed = fallback & ~entering
        blobs = failed_blobs(failed) if failed.any() else failed
        if blobs.any():
            # Not the edges of an object the flow follows (its occlusions).
            if missed is None:
                missed = self._missed(fr)
                followed = followed_objects(self._changing(fr, c_at), missed)
            if followed is not None and followed.any():
                blobs = failed_blobs(failed, followed=followed, missed=missed)
        regions |= blobs
        field, folds, spun, said, fronts, fitted = self._turn_back_spinning(
            fr, field, folds, regions, t_ref, c_at, u_mean, followed)
        notes.append(said)
        events += fitted
        if folds > FOLD_WARNING:  # what shows: the blobs' share where the picture has detail
            folds *= _on_detail(fold_blobs(field, followed), fr.image)
        if folds > FOLD_WARNING:
            notes.append(f"the correction folds or tears {100 * folds:.1f}% of the picture")
            events += ("folds",)
        return field, folds, kept, spun, "; ".join(n for n in notes if n), fronts, events

    def _missed(self, fr: DenseFrame) -> np.ndarray:
        """Pixels the flow to every neighbour that sees them carries onto unlike grey levels.

        :func:`~unjello.motion.flow.dis.misses` on each side, both at once, opened by a 7 px
        disc: the thin lines along a near object's edges (occlusions, seen from one
        side) go, the blobs of a flow that failed on a spinner stay. A side whose flow
        lands more than :data:`BEYOND` px outside the frame cannot tell: an object leaving
        the frame that the other side's flow misses is missed (a near pole at the side,
        which the flow lost, was taken for one it follows and kept the background's
        motion).
        """
        near = {f.index: f for f in self._frames}
        sides = [(misses(near[fr.index + k].image, fr.image, flow), _beyond(flow))
                 for k, flow in ((-1, fr.bwd), (1, fr.fwd))
                 if flow is not None and fr.index + k in near]
        if not sides:
            return np.zeros(fr.image.shape, bool)
        both = (np.logical_and.reduce([m | gone for m, gone in sides])
                & ~np.logical_and.reduce([gone for _, gone in sides])).astype(np.uint8)
        return cv2.morphologyEx(both, cv2.MORPH_OPEN, cv2.getStructuringElement(
            cv2.MORPH_ELLIPSE, (7, 7))).astype(bool)

    def _changing(self, fr: DenseFrame, c_at: Callable[[np.ndarray], np.ndarray]
                  ) -> np.ndarray | None:
        """Pixels unlike both neighbours brought over by the camera (:func:`unlike_neighbours`)."""
        t_rows = self.timing.row_times(fr.image.shape[0], fr.start) - fr.start
        others = [(f.image, f.start - fr.start) for f in self._frames
                  if abs(f.index - fr.index) == 1]
        return unlike_neighbours(fr.image, others, c_at, t_rows)

    def _turn_back_spinning(self, fr: DenseFrame, field: np.ndarray, folds: float,
                            regions: np.ndarray, t_ref: float,
                            c_at: Callable[[np.ndarray], np.ndarray], u_mean: np.ndarray,
                            followed: np.ndarray | None
                            ) -> tuple[np.ndarray, float, float, str, tuple[np.ndarray, ...],
                                       tuple[str, ...]]:
        """Fit rotations to the failed ``regions`` (:func:`keep_spinning`) and use them.

        Rotations with a neighbour on each side, or one and last frame's rotations to
        check against (one side alone tells a rotation's aliases apart too poorly); with
        one side alone (a pair, a clip's ends), drifts along the motion around the object
        (a near pole); and only if the map then folds nowhere else. Returns the field, its
        folds (along the spinning objects' edges, occlusion boundaries, and along the
        ``followed`` objects, not counted), the share spun, a note, the rotations'
        layers in front of the field and the events (``spinning``, ``drifting``: one an
        object).
        """
        others = [(f.image, f.start - fr.start) for f in self._frames
                  if abs(f.index - fr.index) == 1]
        if not regions.any() or not others:
            self._spins = []
            return field, folds, 0.0, "", (), ()

        track = rigid.carried(c_at, u_mean)  # what carries an object: path, row velocity
        # Last frame's rotations, carried to this frame's reference time.
        hints = [(c + track(np.array([t_ref]))[0] - track(np.array([t - fr.start]))[0], om)
                 for c, om, t in self._spins]
        spinning, spins, weight, fitted, fronts = keep_spinning(
            field, fr.image, others, regions, track, t_ref, self.timing.readout, hints=hints,
            rotations=len(others) >= 2 or bool(self._spins))
        self._spins = [(s.centre, s.omega, fr.start + t_ref) for s in fitted]
        if not spins:
            return field, folds, 0.0, "", (), ()
        spun_px = (weight > 0.5).astype(np.uint8)
        k = np.ones((7, 7), np.uint8)
        edges = cv2.dilate(spun_px, k) > cv2.erode(spun_px, k)
        blobs_after = fold_blobs(spinning, followed) & ~edges
        after = float(blobs_after.mean())
        if after * _on_detail(blobs_after, fr.image) > max(folds, FOLD_WARNING):
            # folds elsewhere, where they show: a wrong rotation
            return field, folds, 0.0, "", (), ()
        spun = float(spun_px.mean())
        turning = [s for s in spins if s.omega]
        drifting = [s for s in spins if not s.omega]
        notes = []
        if turning:
            turns = ", ".join(f"{s.omega / (2 * np.pi):+.2f}" for s in turning)
            notes.append(f"{len(turning)} spinning object(s) turned back by a rotation "
                         f"fitted per scanline ({turns} turns per frame)")
        if drifting:
            speeds = ", ".join(f"{np.hypot(*s.drift):.0f}" for s in drifting)
            notes.append(f"{len(drifting)} object(s) moving on their own carried by a "
                         f"velocity fitted per scanline ({speeds} px per frame against the "
                         "motion around them)")
        return spinning, after, spun, (
            f"{'; '.join(notes)}: {100 * spun:.0f}% of the picture"), fronts, (
            ("spinning",) * len(turning) + ("drifting",) * len(drifting))


def _on_detail(blobs: np.ndarray, image: np.ndarray) -> float:
    """Share of the pixels of ``blobs`` where ``image`` shows detail (:data:`DETAIL`); 1 if none."""
    n = int(np.count_nonzero(blobs))
    if not n:
        return 1.0
    k = np.ones((5, 5), np.uint8)
    g = np.asarray(image, np.float32)
    detail = (cv2.dilate(g, k) - cv2.erode(g, k)) >= DETAIL
    return float(np.count_nonzero(blobs & detail)) / n
