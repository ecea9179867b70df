"""Rolling-shutter correction from a gyroscope's log: a rotation per scanline.

* :mod:`~unjello.motion.gyro.method`: the method, its calibration (clock offset, axes,
  focal length) against the footage's flow;
* :mod:`~unjello.motion.gyro.fallback`: the clip handed to the dense method where the
  gyro does not describe the picture.
"""
