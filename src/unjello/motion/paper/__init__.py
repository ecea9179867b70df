"""The seed paper's method (Liang, Chang & Chen, IEEE TIP 2008), stage by stage.

* :mod:`~unjello.motion.paper.global_motion`: V.A, global motion by block matching and a
  2-D histogram peak;
* :mod:`~unjello.motion.paper.velocity`: V.B, per-scanline velocity by Bezier curves
  (eq. 13-19);
* :mod:`~unjello.motion.paper.refine`: V.C, constrained local refinement (eq. 20-25);
* :mod:`~unjello.motion.paper.method`: the three wired into a method; V.D, the
  realignment, is :mod:`unjello.warp`.
"""
