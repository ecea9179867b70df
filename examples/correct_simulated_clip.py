"""Simulate a rolling-shutter pan, correct it with the Python API, print the error.

Run: python examples/correct_simulated_clip.py
"""

import numpy as np
from skimage import data

import unjello
from unjello.metrics import displacement_error

timing = unjello.SensorTiming(readout=0.8)
clip = list(unjello.simulate(data.coffee(), unjello.Motion("diagonal", speed=6.0), timing, 8,
                             size=(320, 240)))
corrected, trajectory = unjello.correct_frames([f.rolling for f in clip], timing)
before = np.mean([displacement_error(None, f.motion) for f in clip])
after = np.mean([displacement_error(e, f.motion)
                 for e, f in zip(trajectory.frames, clip, strict=True)])
print(f"per-scanline displacement error: {before:.3f} px before, {after:.3f} px after")
