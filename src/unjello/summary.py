"""What a run found, as data: the summary every front end prints or stores the same way.

:func:`summarize` reads a corrected clip's :class:`~unjello.trajectory.Trajectory` -- its
frames' fields, not their notes -- into a :class:`RunSummary`: the frames bridged over,
the vibration detected, the frames whose per-pixel motion was given the motion around it
or still folds, the shares of unreliable flow and of content entering the frame, the
frames showing what no frame saw beyond the edge, the gyro's
calibration and the stabilisation. :meth:`RunSummary.warnings` says what a user should be
told, one line each; ``unjello correct`` prints them, ``unjello batch`` writes them into
its JSON lines.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .motion.dense.method import FOLD_WARNING
from .trajectory import Trajectory

__all__ = ["RunSummary", "summarize", "UNSEEN_NOTE"]

#: Frames showing more than this share of what no frame saw are reported.
UNSEEN_NOTE = 0.005


@dataclass(frozen=True)
class RunSummary:
    """A run's findings (see :func:`summarize`).

    Attributes
    ----------
    frames : int
    bridged : int
        Frames whose motion could not be measured (bridged over from their neighbours).
    vibration : float or None
        The wobble (share of the height) for which the vibration window was switched on.
    kept : tuple of (int, float)
        Frames (index, share of the picture) given the motion around a place where the
        per-pixel motion folded or tore it.
    folded : tuple of (int, float)
        Frames whose correction still folds or tears more than
        :data:`~unjello.motion.dense.method.FOLD_WARNING` of the picture.
    spun : tuple of int
        Frames with objects the flow failed on given a fitted rigid motion (spinning
        objects turned back by a rotation, near ones carried by a velocity of their own).
    fallback, entering : float
        Mean share of pixels on the camera model (unreliable flow, or content entering
        the frame), and the part of it entering.
    unseen : tuple of (int, float)
        Frames (index, share of the picture) showing, beyond the frame's edge, what no
        frame saw (the edge repeated, or black): over :data:`UNSEEN_NOTE` of the picture.
    calibration : str
        The gyro method's calibration (axes, offset, focal, agreement); '' otherwise.
    stabilized : dict or None
        ``smoothness``, ``crop``, ``zoom`` (min, max) and ``largest_shift`` (x, y px).
    """

    frames: int
    bridged: int = 0
    vibration: float | None = None
    kept: tuple[tuple[int, float], ...] = ()
    folded: tuple[tuple[int, float], ...] = ()
    spun: tuple[int, ...] = ()
    fallback: float = 0.0
    entering: float = 0.0
    unseen: tuple[tuple[int, float], ...] = ()
    calibration: str = ""
    stabilized: dict | None = None

    def warnings(self) -> list[str]:
        """Return what a user should be told, one line each (warnings start 'warning:')."""
        out = []
        if self.bridged and self.frames > 1:
            out.append(f"warning: motion bridged over on {self.bridged} frame(s)")
        if self.calibration:
            out.append(self.calibration)
        if self.vibration is not None:
            out.append(f"vibration detected (wobble {100 * self.vibration:.2f}% of the height)"
                       ": one-second window, as with --vibration on (--vibration off: never)")
        if self.kept:
            index, share = max(self.kept, key=lambda k: k[1])
            # What the output shows (whole objects), not what was repaired on the way.
            out.append(f"kept whole: on {len(self.kept)} frame(s) an object moved in a way "
                       f"the per-pixel motion could not follow (a fast-spinning object?); it "
                       f"is shown whole, moved with what is around it (at most "
                       f"{100 * share:.0f}% of frame {index})")
        if self.folded:
            index, share = max(self.folded, key=lambda k: k[1])
            out.append(f"warning: the correction folds or tears the picture on "
                       f"{len(self.folded)} frame(s) (worst: {100 * share:.1f}% of frame "
                       f"{index}): motion that unjello does not follow, such as a "
                       "fast-spinning object; compare them with the input")
        if self.fallback - self.entering > 0.1:
            out.append(f"warning: the flow was unreliable on "
                       f"{100 * (self.fallback - self.entering):.0f}% of the pixels (flat "
                       "areas, occlusions, fast-moving objects); they take the motion of "
                       "their reliable surroundings")
        if self.entering > 0.1:
            out.append(f"{100 * self.entering:.0f}% of the pixels show content entering the "
                       "frame, which no neighbour saw: they take the motion of their "
                       "surroundings")
        if self.unseen:
            index, share = max(self.unseen, key=lambda k: k[1])
            out.append(f"beyond the frame's edge: on {len(self.unseen)} frame(s) the "
                       f"correction shows what no frame saw (at most {100 * share:.1f}% of "
                       f"frame {index}); the edge is repeated there (black with --fill "
                       "black)")
        if self.stabilized:
            z, s = self.stabilized["zoom"], self.stabilized["largest_shift"]
            out.append(f"stabilised: camera path smoothed over "
                       f"{self.stabilized['smoothness']:g} s; zoom {z[0]:.3f}-{z[1]:.3f}; "
                       f"shifts up to {s[0]:.1f} px across, {s[1]:.1f} px along the scan "
                       "(top-bottom orientation)")
        return out


    def as_json(self, traj: Trajectory) -> dict:
        """Return the findings and the per-frame figures, as ``correct --json`` gives them."""
        return {"frames": len(traj), "method": traj.method, "readout": traj.timing.readout,
                "direction": traj.timing.direction, "reference": traj.timing.reference,
                "bridged_frames": self.bridged, "fallback_fraction": round(self.fallback, 4),
                "entering_fraction": round(self.entering, 4),
                "kept_frames": [i for i, _ in self.kept],
                "folded_frames": [i for i, _ in self.folded],
                "folds": [round(f.diagnostics.folds, 4) for f in traj.frames],
                "unseen": [round(f.diagnostics.unseen, 4) for f in traj.frames],
                "spun_frames": list(self.spun), "vibration": self.vibration,
                "confidence": [round(f.confidence, 3) for f in traj.frames],
                "stabilized": self.stabilized,
                "stretches": [s.as_json() for s in traj.stretches]}


def summarize(traj: Trajectory, stabilize: tuple[float, object] | None = None) -> RunSummary:
    """Read a corrected clip's trajectory into a :class:`RunSummary`.

    Parameters
    ----------
    traj : Trajectory
        The run's motion (its frames' fields; ``vibration`` as the run set it).
    stabilize : (float, crop), optional
        The stabilisation's smoothness and crop, when it was on.
    """
    frames = traj.frames
    said = [(f, f.diagnostics) for f in frames]
    n = len(frames)
    stabilized = None
    if stabilize is not None and n:
        zooms = [f.reframe.zoom for f in frames]
        shifts = np.abs([f.reframe.shift for f in frames]).max(axis=0)
        stabilized = {"smoothness": stabilize[0], "crop": stabilize[1],
                      "zoom": [round(min(zooms), 4), round(max(zooms), 4)],
                      "largest_shift": [round(float(v), 2) for v in shifts]}
    return RunSummary(
        frames=n,
        bridged=sum(not f.ok for f in frames),
        vibration=traj.vibration,
        kept=tuple((f.index, d.kept) for f, d in said if d.kept > 0),
        folded=tuple((f.index, d.folds) for f, d in said if d.folds > FOLD_WARNING),
        spun=tuple(f.index for f, d in said if d.spun > 0),
        fallback=float(np.mean([d.fallback for _, d in said])) if n else 0.0,
        entering=float(np.mean([d.entering for _, d in said])) if n else 0.0,
        unseen=tuple((f.index, d.unseen) for f, d in said if d.unseen > UNSEEN_NOTE),
        calibration=frames[0].note if traj.method == "gyro" and n else "",
        stabilized=stabilized)
