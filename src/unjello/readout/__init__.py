"""The readout time: measured, estimated from footage, or looked up.

* :mod:`~unjello.readout.flicker`: measured from a frame of a flickering light;
* :mod:`~unjello.readout.footage`: estimated from the footage's motion (a trajectory
  fitted at each candidate readout) and its straight lines;
* :mod:`~unjello.readout.lines`: the lean of lines straight in the world;
* :mod:`~unjello.readout.cameras`: the camera database (readout, scan direction, lens).
"""
