"""End to end on simulated clips, shared by the method tests: correct and measure."""

import numpy as np

from unjello.config import CorrectionConfig
from unjello.metrics import displacement_error
from unjello.pipeline import correct_frames
from unjello.simulate import simulate

SIZE = (224, 160)


def run_simulated(scene, motion, timing, n=10, config=CorrectionConfig(), starts=None):
    """Simulate, correct; return (sim, corrected, trajectory, error, uncorrected error)."""
    sim = list(simulate(scene, motion, timing, n, size=SIZE, frame_starts=starts))
    out, traj = correct_frames([s.rolling for s in sim], timing, config=config, starts=starts)
    err = np.array([displacement_error(f, s.motion) for f, s in zip(traj.frames, sim, strict=True)])
    unc = np.array([displacement_error(None, s.motion) for s in sim])
    return sim, out, traj, err, unc
