"""What a frame did not see, filled from the frames that saw it.

* :mod:`~unjello.warp.fill.planes`: :class:`~unjello.warp.fill.planes.NeighbourFill`, the
  order of the fills below over one picture's planes;
* :mod:`~unjello.warp.fill.neighbours`: beyond the frame's edge, from the neighbours;
* :mod:`~unjello.warp.fill.uncovered`: background a nearer object uncovered;
* :mod:`~unjello.warp.fill.leaving`: a nearer object leaving the frame at a side,
  carried beyond its edge.
"""
