"""What reads a Trajectory besides the warp.

* :mod:`~unjello.exports.outputs`: the motion JSON, STMaps, plots, side-by-side views,
  written beside the clip as it is corrected;
* :mod:`~unjello.exports.gyroflow`: the motion as a Gyroflow project and log.
"""
