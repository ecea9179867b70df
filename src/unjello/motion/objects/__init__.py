"""What the camera model cannot explain: folds, spinning objects, objects on their own.

* :mod:`~unjello.motion.objects.folds`: where a per-pixel correction folds or tears, and
  the regions given their surroundings' motion;
* :mod:`~unjello.motion.objects.rigid`: an object's rigid motion imaged row by row,
  scored against the neighbouring frames;
* :mod:`~unjello.motion.objects.support`: a fitted object's region, its shape, and the
  pixels its motion explains;
* :mod:`~unjello.motion.objects.spinners`: a spinning or passing object fitted a rotation
  or a drift of its own.
"""
