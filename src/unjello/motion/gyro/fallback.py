"""The gyro method, handing the clip to the dense method when the gyro does not fit.

A camera's own gyro is not always a description of its picture: a camera on a gimbal
hardly rotates while the picture moves with the vehicle, and a camera that stabilised
its picture itself (GoPro HyperSmooth) has already undone the rotation its gyro records.
:class:`GyroOrDense` runs the gyro method; while it calibrates (its first ``sync_frames``)
it keeps the frames, and when the calibration finds that the gyro explains too little of
the picture's motion (:class:`~unjello.motion.gyro.method.GyroMismatch`) -- or the caller knows
beforehand that it cannot describe it -- it gives them to the dense method, which then
measures the whole clip: the same motion as asking for the dense method.
"""

from __future__ import annotations

from collections.abc import MutableMapping

import numpy as np

from ...gyrolog import GyroConfig, GyroLog
from ...timing import SensorTiming
from ...trajectory import FrameMotion
from ..dense.method import DenseConfig, DenseMethod
from .method import GyroMethod, GyroMismatch

__all__ = ["GyroOrDense"]


class GyroOrDense:
    """Streaming gyro method with a hand-over to the dense method.

    Parameters
    ----------
    timing : SensorTiming
    log : GyroLog
    gyro : GyroConfig
    dense : DenseConfig
        The dense method's settings, should it take over.
    fps : float
    flows : mutable mapping, optional
        The dense method's flow cache (:class:`~unjello.motion.dense.method.DenseMethod`).
    fallback : bool or str
        False: a gyro that does not fit raises :class:`~unjello.motion.gyro.method.GyroMismatch`
        (a log the user gave: the wrong file, layout or units). True: the dense method
        takes over. A string: a reason known beforehand not to use the gyro; it is still
        calibrated, to say how much it explains, and the dense method measures.

    Attributes
    ----------
    method : str
        ``'gyro'``, or ``'dense'`` once handed over.
    fallback : str
        Why the gyro was not used; empty when it was.
    agreement : float or None
        Share of the picture's row motion the gyro explains, once known.
    """

    def __init__(self, timing: SensorTiming, log: GyroLog, gyro: GyroConfig,
                 dense: DenseConfig, fps: float,
                 flows: MutableMapping[tuple, tuple] | None = None,
                 fallback: bool | str = False) -> None:
        self.timing = timing
        self.gyro = GyroMethod(timing, log, gyro, fps)
        self._dense_config = dense
        self._flows = flows
        self._distrust = fallback if isinstance(fallback, str) else ""
        self._method: GyroMethod | DenseMethod = self.gyro
        self.method = "gyro"
        self.fallback = ""
        self.agreement: float | None = None
        # The frames the calibration holds, for the dense method should the gyro not fit.
        self._held: list[tuple[np.ndarray, float]] | None = [] if fallback else None
        if self.gyro.calibration is not None:  # all given: nothing to calibrate
            if self._distrust:
                self._hand_over(self._distrust, final=False)
            self._held = None

    @property
    def wobble(self) -> float | None:
        """The dense method's detected vibration after a hand-over (None before, or none)."""
        return getattr(self._method, "wobble", None)
    def push(self, frame: np.ndarray, start: float) -> list[FrameMotion]:
        """Add the next frame (grey, 0-255, top-bottom) starting at ``start``."""
        return self._measure((frame, start))

    def flush(self) -> list[FrameMotion]:
        """Return the motion of the frames still pending."""
        return self._measure(None)

    def pose(self, start: float) -> np.ndarray | None:
        """Return the gyro's pose at a frame's reference time, or None once handed over.

        See :meth:`unjello.motion.gyro.method.GyroMethod.pose`.
        """
        return self.gyro.pose(start) if self.method == "gyro" else None

    def _measure(self, frame: tuple[np.ndarray, float] | None) -> list[FrameMotion]:
        if self._held is not None and frame is not None:
            self._held.append(frame)
        try:
            motions = self._method.push(*frame) if frame is not None else self._method.flush()
        except GyroMismatch as mismatch:
            if self._held is None:
                raise
            self.agreement = mismatch.agreement
            return self._hand_over(self._distrust or (
                f"{mismatch.summary} in the first frames (a camera on a gimbal, or one that "
                "stabilised its picture, moves otherwise)"), final=frame is None)
        cal = self.gyro.calibration
        if self.method == "gyro" and cal is not None and self.agreement is None:
            self.agreement = cal.agreement
            if self._distrust:
                return self._hand_over(self._distrust, final=frame is None)
            self._held = None
        return motions

    def _hand_over(self, why: str, final: bool) -> list[FrameMotion]:
        """Give the held frames to the dense method, which measures from now on."""
        self.fallback, self.method = why, "dense"
        self._method = DenseMethod(self.timing, self._dense_config, self._flows)
        held, self._held = self._held or [], None
        motions = [m for frame in held for m in self._method.push(*frame)]
        return motions + self._method.flush() if final else motions
