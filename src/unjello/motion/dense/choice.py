"""The dense method's camera model, chosen by the footage: smooth or vibrating.

:class:`ModelChoice` holds the steps of :class:`~unjello.motion.dense.method.DenseMethod` that
choose its camera model from the probed frame pairs
(:func:`~unjello.motion.dense.vibration.choose_model`), at the start and again each ``probe``
pairs with contrast after, and that measure the held pairs' flows again at the
vibration's full detail when it switches to vibration.
"""

from __future__ import annotations

from collections import deque
from concurrent.futures import Future
from typing import TYPE_CHECKING, Any

import numpy as np

from .vibration import VIBRATION, choose_model, pick_frequencies

if TYPE_CHECKING:
    from ...timing import SensorTiming
    from ..flow.dis import FlowSettings
    from .config import DenseConfig
    from .safety import DenseFrame

__all__ = ["ModelChoice"]


class ModelChoice:
    """The camera model's choice and switch (a mixin of the dense method).

    It reads the method's ``timing``, settings (``config``, and ``_base``: those of
    ``vibration='auto'``), frames and flows, and sets ``config``, :attr:`choice`,
    :attr:`decisions` and ``wobble``.
    """

    timing: SensorTiming
    config: DenseConfig
    _base: DenseConfig
    _frames: deque[DenseFrame]
    _halves: list[tuple]
    _decided: bool
    _next_out: int
    _note: str
    _freqs: Any
    _final: bool
    _auto: bool
    _equations: deque[tuple[int, tuple]]
    _pending: deque[tuple[DenseFrame, DenseFrame, Any]]
    _flow_settings: FlowSettings
    choice: dict[str, float]
    decisions: list[tuple[int, str, dict[str, float]]]
    wobble: float | None
    vibrating: bool | None
    _measure: Any
    _keep_flows: Any
    _row_equations: Any

    def _decide(self) -> None:
        """Choose the camera model on the pairs probed since the last choice (:func:`choose_model`).

        The first choice holds from the first frame. Under the smooth model the choice is
        made again on each next ``probe`` pairs with contrast, and a switch to vibration
        holds from the next frame out (:attr:`decisions`): a drone that takes off. The
        vibration model, once chosen, stays for the stretch: switching back after a
        drone landed came out worse (0.188 -> 0.241x, ``docs/matrix.md``), and later
        choices on a vibrating clip went back and forth.
        """
        first, self._decided = not self._decided, True
        halves, self._halves = self._halves, []
        if not self._frames or len(halves) < self.config.probe:  # (too short to gain)
            self.choice = self.choice or {"pairs": len(halves)}
            return
        step = max(self.timing.readout / self.config.grid, 1.0 / 256)
        vibrating, choice = choose_model(halves, self._frames[0].image.shape[0],
                                         self.timing.readout, step, self._base.smoothness)
        self.choice = self.choice or choice
        if not first and vibrating == self.vibrating:
            return
        self.decisions.append((self._next_out, "vibration" if vibrating else "smooth", choice))
        self._freqs = None
        self.config = self._base.vibrating() if vibrating else self._base
        self._note = (f"vibration detected (wobble {100 * choice['wobble']:.2f}% of the "
                      "height): one-second window") if vibrating else ""
        if vibrating:
            self.wobble = self.wobble or choice["wobble"]
            self._remeasure()

    def _kept_pairs(self) -> int:
        """Return how many pairs' row equations to keep.

        A window's, and under ``auto`` a vibration window's, so that a switch to vibration
        sees the pairs before it (a drone that takes off: its first frames of vibration
        0.47 px off without them, 0.18 with them; ``docs/matrix.md``).
        """
        span = self.config.history + self.config.window
        return max(span, VIBRATION["history"] + VIBRATION["window"]) if self._auto else span

    def _frequencies(self, pairs: tuple[int, int], t_a: np.ndarray, t_b: np.ndarray,
                     delta: np.ndarray, wgt: np.ndarray) -> np.ndarray:
        """Return the vibration's frequencies for the window ``pairs`` (:func:`pick_frequencies`).

        They hold for a while: picked again once the window's end has moved 8 pairs, from
        every 4th row equation (the choice costs far more than the solve), and once more
        for the clip's last frames, whose window stands still at its end (picked 5 pairs
        earlier, a drone that took off ended up to 0.44 px off, 0.28 picked on it).
        """
        if (self._freqs is None or pairs[1] - self._freqs[0][1] >= 8
                or (self._final and pairs != self._freqs[0])):
            sub = slice(None, None, 4)
            self._freqs = (pairs, pick_frequencies(t_a[sub], t_b[sub], delta[sub], wgt[sub],
                                                   self.config.sinusoids))
        return self._freqs[1]

    def _remeasure(self) -> None:
        """Measure the probed pairs' polished flows again, at the vibration's full detail.

        Under a vibration model the polished flows of the probe cost the simulated drone
        jello 0.06x (0.644x -> 0.704x of the uncorrected error; ``docs/history/measurements.md``);
        the frames are all still held while the probe decides, so their flows are measured
        again (once per vibrating clip), and the pairs already started too: every pair
        measured with other settings than the vibration's (whatever the polish).
        """
        if not self.config.per_pixel:
            return
        full = self._flow_settings
        held = list(self._frames)
        redo = [(prev, cur) for prev, cur in zip(held, held[1:], strict=False)
                if cur.bwd is not None and cur.settings not in (None, full)]
        jobs = [self._measure(prev, cur) for prev, cur in redo]
        for (prev, cur), job in zip(redo, jobs, strict=True):
            job = job.result() if isinstance(job, Future) else job
            self._keep_flows(prev, cur, job)
            cur.bwd, cur.bwd_ok, prev.fwd, prev.fwd_ok = job
        again = {cur.index: (prev, cur) for prev, cur in redo}
        self._equations = deque((i, self._row_equations(*again[i]) if i in again else eq)
                                for i, eq in self._equations)
        self._pending = deque((prev, cur, self._measure(prev, cur)
                               if cur.settings not in (None, full) else job)
                              for prev, cur, job in self._pending)
