"""The default method: per-pixel motion over a scanline-resolution camera trajectory.

The stages of :class:`~unjello.motion.dense.method.DenseMethod`, as a frame meets them
(``push`` and ``_emit`` call them in this order; the table with their rules, tests and
benchmarks: ``docs/method.md``):

1. **flow**: each frame pair's flows both ways (:mod:`unjello.motion.flow`), measured
   ahead on threads and taken in order;
2. **row equations**: each row's robust flow, one equation on the camera's path;
3. **camera model**: smooth or vibrating, chosen by the footage
   (:mod:`~unjello.motion.dense.choice`, :mod:`~unjello.motion.dense.vibration`);
4. **camera trajectory**: all rows of the frames around solved together
   (:mod:`~unjello.motion.dense.camera`);
5. **per-pixel residual and field**: what the camera does not explain, filled and
   smoothed (:mod:`~unjello.motion.dense.method`, :mod:`~unjello.motion.dense.field`);
6. **do no harm**: folds and tears kept whole, objects fitted a rigid motion of their
   own (:mod:`~unjello.motion.dense.safety`, :mod:`unjello.motion.objects`);
7. **the neighbours' flows**: what the frames either side saw beyond this one's edge,
   for the warp's fill (:mod:`unjello.warp.fill`).

Its settings: :mod:`~unjello.motion.dense.config`.
"""
