"""Correct a simulated hand-shake clip from its gyroscope log, with the Python API.

The log is on another clock (12.3 s ahead) and mounted with other axes; the method finds
both, and the focal length, from the footage before correcting.

Run: python examples/correct_with_gyro.py
"""

import tempfile
from pathlib import Path

import numpy as np
from skimage import data

import unjello
from unjello.gyrolog import axes_matrix
from unjello.metrics import displacement_error

timing = unjello.SensorTiming(readout=0.9)
motion = unjello.Motion("shake", fps=30.0)
clip = list(unjello.simulate(data.astronaut(), motion, timing, 45, size=(320, 240)))
t, rates = unjello.gyro_samples(motion, focal=2560.0, duration=45 / 30,
                                axes=axes_matrix("Zxy"), start=12.3, noise=0.002)
with tempfile.TemporaryDirectory() as tmp:
    log = Path(tmp) / "clip.gyro.csv"
    unjello.write_gyro(log, t, rates)
    config = unjello.CorrectionConfig().with_options(gyro=str(log))  # implies method="gyro"
    corrected, trajectory = unjello.correct_frames([f.rolling for f in clip], timing,
                                                   config=config)
print(trajectory.frames[0].note)
before = np.mean([displacement_error(None, f.motion) for f in clip])
after = np.mean([displacement_error(e, f.motion)
                 for e, f in zip(trajectory.frames, clip, strict=True)])
print(f"per-scanline displacement error: {before:.3f} px before, {after:.3f} px after")
