"""A clip's settings, decided once: its timing, its lens and its gyro.

:func:`resolve_clip` is what :func:`unjello.pipeline.correct_video` and the segmented
run (:mod:`unjello.segments`) both call before any frame is corrected: the readout,
direction, reference and frame rate (:func:`unjello.config.resolve_timing`, with the
camera the file names and the estimate from its motion), the lens a profile or the camera
database knows, and the gyro log with what is known of it.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from .cameras import match
from .config import CorrectionConfig, ResolvedTiming, resolve_timing
from .io.sidecars import gyro_source, read_lens_profile
from .io.source import FrameSource
from .io.telemetry import camera_of
from .motion.gyro import GyroLog
from .readout import estimate_readout_file
from .trajectory import Trajectory

__all__ = ["resolve_clip"]


def resolve_clip(config: CorrectionConfig, src_p: Path, source: FrameSource,
                 given: Trajectory | None = None
                 ) -> tuple[CorrectionConfig, ResolvedTiming, GyroLog | None, Any, dict, str]:
    """Decide a clip's timing, lens and gyro once (:func:`correct_video`, segments).

    Returns
    -------
    config : CorrectionConfig
        With the lens found for it.
    resolved : ResolvedTiming
    gyro_log, own : the gyro method's log, and the camera's own record (or None)
    report : dict
        What will be said of the gyro.
    distrust : str
        Why the camera's own gyro cannot describe the picture ('' if it can).
    """
    gyro = config.method == "gyro" and given is None
    identified = (camera_of(src_p) if given is None and not config.camera
                  and not config.lens_profile
                  and (config.readout in (None, "auto") or gyro or config.undistort)
                  else None)
    resolved = resolve_timing(
        config, path=src_p, video_fps=source.info.fps,
        motion_timing=given.timing if given is not None else None,
        size=(source.info.width, source.info.height), identified=identified,
        estimate=lambda direction, fps: estimate_readout_file(src_p, direction=direction,
                                                              fps=fps))
    gyro_log, own, report, distrust = None, None, {}, ""
    if gyro or config.undistort:
        config, lens = _with_lens(config, config.camera or identified,
                                  (source.info.width, source.info.height), resolved.fps)
        resolved = dataclasses.replace(resolved, messages=(*resolved.messages, *lens))
    if gyro:
        gyro_log, said, own = gyro_source(src_p, config.gyro)
        resolved = dataclasses.replace(
            resolved, sources={**resolved.sources, "gyro": said},
            messages=(*resolved.messages, f"gyro: {said}"))
        report = {"source": said, "used": True, "explains": None, "why": ""}
        if own is not None and own.stabilised:
            distrust = (f"the camera stabilised the picture itself (stabilisation "
                        f"{own.stabilised!r}), so it no longer moves as the gyro says")
    return config, resolved, gyro_log, own, report, distrust


def _with_lens(config: CorrectionConfig, camera: str | None, size: tuple[int, int],
               fps: float) -> tuple[CorrectionConfig, tuple[str, ...]]:
    """Give the gyro method the lens a profile or the camera database knows.

    Only what is not given: ``focal`` and ``distortion`` of :class:`GyroConfig`.
    """
    g = config.gyro
    if g.focal is not None and g.distortion is not None:
        return config, ()
    lens, source = None, ""
    if config.lens_profile:
        profile = read_lens_profile(config.lens_profile)
        lens, source = profile.lens(size[0]), f"lens profile {profile.name}"
    elif camera:
        found = match(camera, size[0], size[1], fps)
        if found is not None and found.focal is not None and found.k is not None:
            lens, source = (found.focal, found.k), f"camera database ({found.camera})"
    if lens is None:
        return config, ()
    focal = g.focal if g.focal is not None else lens[0]
    coef = g.distortion if g.distortion is not None else tuple(lens[1])
    new = dataclasses.replace(config, gyro=dataclasses.replace(
        g, focal=focal, distortion=coef))  # type: ignore[arg-type]
    return new, (f"lens from the {source}: focal {focal:.0f} px, fisheye k "
                 + ", ".join(f"{v:.3g}" for v in coef),)
