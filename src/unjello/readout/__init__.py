"""The readout time: measured, estimated from footage, or looked up.

* :mod:`~unjello.readout.footage`: from a flicker frame, or from the footage's motion
  (a trajectory fitted at each candidate readout) and its straight lines;
* :mod:`~unjello.readout.lines`: the lean of lines straight in the world;
* :mod:`~unjello.readout.cameras`: the camera database (readout, scan direction, lens).
"""
