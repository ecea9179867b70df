"""The optical flow the methods share: DIS, its inverse, patches, phase correlation.

* :mod:`~unjello.motion.flow.phase`: a frame pair's dominant translation, the flow's
  starting point for fast pans;
* :mod:`~unjello.motion.flow.dis`: DIS optical flow each way, its consistency check,
  the row flows, the pair's flows (:func:`~unjello.motion.flow.dis.flow_pair`);
* :mod:`~unjello.motion.flow.inverse`: a flow's inverse (where the other frame's pixels
  came from);
* :mod:`~unjello.motion.flow.patches`: flows scored over patches, sharpened at motion
  boundaries, and content entering the frame.
"""
