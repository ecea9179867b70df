"""Replaying a stored motion: a "method" that hands back a Trajectory's frames in order.

``correct --motion-in`` applies a motion JSON written by ``--motion-out`` (edited, or from
another run) instead of estimating it.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..trajectory import FrameMotion, Trajectory

__all__ = ["Replay"]


class Replay:
    """A "method" that hands back the frames of a stored Trajectory, in order."""

    def __init__(self, traj: Trajectory) -> None:
        self._frames = {f.index: f for f in traj.frames}
        self._n = 0

    def push(self, frame: np.ndarray, start: float) -> list[FrameMotion]:
        """Return the stored motion of the next frame (checked against its height)."""
        fm = self._frames.get(self._n)
        if fm is None:
            raise InputError(f"the motion file has no frame {self._n}")
        if fm.displacement.shape[0] != frame.shape[0]:
            raise InputError("the motion file was made for frames of another size")
        self._n += 1
        return [fm]

    def flush(self) -> list[FrameMotion]:
        """Return nothing: every frame was handed back as it came."""
        return []
