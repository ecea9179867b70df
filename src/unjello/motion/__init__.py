"""Motion estimation: methods that turn frames into a Trajectory's frames.

A method takes grey frames (top to bottom) with their start times and returns
:class:`~unjello.trajectory.FrameMotion` records; it reads no file and warps nothing.

* :mod:`unjello.motion.dense`: the default, per-pixel motion over a camera trajectory
  at scanline resolution;
* :mod:`unjello.motion.paper`: the seed paper's stages V.A-V.C;
* :mod:`unjello.motion.gyro`: a rotation per scanline from a gyro log;
* :mod:`unjello.motion.flow`: the optical flow they share;
* :mod:`unjello.motion.objects`: what the camera model cannot explain (folds, spinners,
  objects drifting on their own);
* :mod:`~unjello.motion.cuts`: where a clip breaks (a cut, a flash, a size change);
* :mod:`~unjello.motion.replay`: a stored motion handed back in order.
"""
