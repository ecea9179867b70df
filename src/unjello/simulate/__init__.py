"""Render rolling-shutter clips with known motion: the ground truth of every test.

A static scene image ``I`` (or a global-shutter video, one scene per frame) is filmed
by a camera whose image-plane displacement is ``D(t)`` (px, time in frame intervals):
the global-shutter frame at time ``t`` is ``G_t(p) = I(p + o - D(t))`` for a crop
origin ``o``, so a static scene point appears at ``w - o + D(t)``. A rolling-shutter
frame takes each scanline ``r`` from the global-shutter frame of its own time (eq. 2):
``S_n(x, r) = G_{t_r}(x, r)`` with ``t_r = t_n + rho r / h`` (:mod:`unjello.timing`);
with an exposure ``e`` (in frame intervals) it averages ``G_t`` over
``[t_r - e, t_r]``. The truth is ``G_{t_ref}`` of each frame, and the true
per-scanline displacement is ``D(t_r) - D(t_ref)``: exactly what a method's
:class:`~unjello.trajectory.FrameMotion` estimates.

Rendering happens in the sensor's top-bottom orientation (:func:`unjello.timing.to_top_bottom`)
and is turned back, so the scan direction is honoured and ``D`` is along the sensor's
rows and columns. With a video source, the scene changes from frame to frame (the
content of source frame ``n`` is used for every scanline of frame ``n``); only the
camera's own motion is rolling-shutter distorted, and that is what the truth describes.

Scenes: ``planar`` (one depth), ``parallax`` (a disc at half the depth, moving twice
as far), ``object`` (a disc moving on its own), ``propeller`` and ``wheel`` (spinning),
``poles`` (flat poles passing in front, 2.2 times as near); with layers the truth is per pixel.

Motions (all return ``D(t)`` in px, ``t`` in frame intervals, for a frame rate ``fps``):
``pan`` (constant velocity), ``stop`` (pan, then a sudden stop half way, the paper's
Fig. 7), ``diagonal`` (pan in x and y), ``shake`` (hand shake: sinusoids of 1.5-9 Hz),
``walk`` (3.6 times that shake on a pan),
``jello`` (drone vibration: 23-40 Hz, a few px, on a slow pan), or a JSON file
``{"time_unit": "frame" | "s", "t": [...], "dx": [...], "dy": [...]}`` interpolated
by a cubic spline.
"""

from .clip import read_scene, simulate_clip
from .lens import RotatingFrame, simulate_rotation
from .lines import street_scene
from .motion import MOTIONS, Motion, Vibration, gyro_samples, motion_from_spec
from .render import SCENES, Layer, SimulatedFrame, pole_layers, scene_layers, simulate

__all__ = ["Motion", "MOTIONS", "Vibration", "SCENES", "Layer", "SimulatedFrame", "simulate",
           "motion_from_spec", "scene_layers", "pole_layers", "gyro_samples", "read_scene",
           "simulate_clip", "RotatingFrame", "simulate_rotation", "street_scene"]
