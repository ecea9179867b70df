"""A clip's settings, decided once: its timing, its lens and its gyro.

:func:`resolve_clip` is what :func:`unjello.pipeline.correct_video` and the segmented
run (:mod:`unjello.run.segments`) both call before any frame is corrected: the readout,
direction, reference and frame rate (:func:`resolve_timing`, with the
camera the file names and the estimate from its motion), the lens a profile or the camera
database knows, and the gyro log with what is known of it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .config import FOLDER_FPS, CorrectionConfig
from .errors import SettingsError
from .gyrolog import GyroLog
from .io.gcsv import is_gcsv, read_gcsv, stated_calibration
from .io.sidecars import LensProfile, find_gyro_log, gyro_source, read_lens_profile, stated_readout
from .io.source import FrameSource
from .io.telemetry import camera_of
from .io.video import is_pipe, probe, variable_rate
from .lens import Lens
from .readout.cameras import CameraMatch, match
from .readout.footage import estimate_readout_file
from .timing import Milliseconds, SensorTiming
from .trajectory import Trajectory

__all__ = ["resolve_clip", "resolve_timing", "ResolvedTiming", "describe", "database_readout",
           "with_lens"]



@dataclass(frozen=True)
class ResolvedTiming:
    """The timing a clip is corrected with, and where each value came from.

    Attributes
    ----------
    timing : SensorTiming
        Readout (a fraction), direction, reference.
    fps : float
        The frame rate whose interval is the unit of time.
    sources : dict
        ``readout``, ``direction``, ``reference`` and ``fps`` -> where the value came
        from (``"command line"``, ``"preset drone"``, ``"sidecar NAME.json"``,
        ``"container metadata"``, ``"estimated from the motion (...)"`` (naming the
        cue and its confidence), ``"motion file"``,
        ``"the video"``, ``"default"``).
    messages : tuple of str
        What the user should be told (a readout found or estimated, a weak estimate, a
        stated readout the footage contradicts).
    estimate : ReadoutEstimate, optional
        What the footage said of the readout, where it was asked.
    """

    timing: SensorTiming
    fps: float
    sources: Mapping[str, str]
    messages: tuple[str, ...] = ()
    estimate: Any = None


def resolve_timing(config: CorrectionConfig, *, path: Path, video_fps: float | None,
                   motion_timing: SensorTiming | None = None,
                   estimate: Callable[[str, float], Any] | None = None,
                   size: tuple[int, int] | None = None,
                   identified: str | None = None,
                   profile: LensProfile | None = None) -> ResolvedTiming:
    """Decide readout, direction, reference and frame rate, in the documented order.

    Parameters
    ----------
    config : CorrectionConfig
        The settings (their :attr:`~CorrectionConfig.origins` say who gave them).
    path : Path
        The clip (its sidecars and metadata are read for a stated readout).
    video_fps : float or None
        The video's own frame rate; None for a folder.
    motion_timing : SensorTiming, optional
        The timing of a motion file being applied: it wins.
    estimate : callable, optional
        ``estimate(direction, fps)`` returning a
        :class:`~unjello.readout.footage.ReadoutEstimate`, for ``readout="auto"`` when nothing
        states the readout.
    size : (int, int), optional
        The clip's width and height, to pick the camera's modes in the database.
    identified : str, optional
        The camera the file names (:func:`unjello.io.telemetry.camera_of`), used when
        ``camera`` is not given.
    profile : LensProfile, optional
        The lens profile ``lens_profile`` names, read once by the caller (default: read
        here).

    Notes
    -----
    The readout, in order: the settings (command line, preset); a lens profile given
    (``lens_profile``); a sidecar or the file's metadata (:func:`stated_readout`); the
    camera database (:func:`unjello.readout.cameras.match`) for the camera given or the one the
    file names; the estimate (``readout="auto"``); 1.0. The direction: the settings,
    else the database's sign of the readout, else top to bottom.

    Returns
    -------
    ResolvedTiming

    Raises
    ------
    SettingsError
        A readout in milliseconds for a folder without ``fps``, or one that is more than
        a frame interval at the clip's rate.
    """
    if profile is None and config.lens_profile:
        profile = read_lens_profile(config.lens_profile)
    given = config.origins
    sources: dict[str, str] = {}
    messages: list[str] = []
    if config.fps is not None:
        fps, sources["fps"] = float(config.fps), given.get("fps", "settings")
    elif video_fps:
        fps, sources["fps"] = float(video_fps), "the video"
    else:
        fps, sources["fps"] = FOLDER_FPS, "default"
    if motion_timing is not None:
        sources.update(readout="motion file", direction="motion file", reference="motion file")
        return ResolvedTiming(motion_timing, fps, sources)
    direction = config.direction or "top-bottom"
    sources["direction"] = given.get("direction", "settings") if config.direction else "default"
    reference = config.reference or "middle"
    sources["reference"] = given.get("reference", "settings") if config.reference else "default"

    def ratio(ms: Milliseconds) -> float:
        if sources["fps"] == "default":
            raise SettingsError(f"a readout of {ms} needs the frame rate: a folder states "
                                "none; give fps=")
        return ms.ratio(fps)

    request = config.readout
    readout: float
    est = None
    if request is not None and request != "auto":
        sources["readout"] = given.get("readout", "settings")
        readout = ratio(request) if isinstance(request, Milliseconds) else float(request)
    else:
        stated = None
        if profile is not None:
            stated = profile.readout
            if stated is None:
                messages.append(f"the lens profile {profile.name} states no "
                                "frame_readout_time")
        stated = stated or (None if is_pipe(path) else stated_readout(path))
        found, vague = (None, "") if stated is not None else _database(config, identified,
                                                                        size, fps)
        if vague:
            messages.append(vague)
        if (found is not None and not found.same_aspect and request == "auto"
                and estimate is not None):
            # A readout borrowed from sensor modes of another aspect ratio is a guess: a
            # reliable estimate from the clip's own motion goes first.
            est = estimate(direction, fps)
            if est.reliable:
                messages.append(f"the camera database has no mode of {found.camera} like "
                                "this clip's, so its readout is not used")
                found = None
            else:
                why = est.note or "the motion is too weak or too uniform to tell"
                messages.append(f"the footage cannot tell its readout: {why} "
                                f"(confidence {est.confidence:.2f})")
        if stated is not None:
            sources["readout"] = stated.source
            readout = ratio(Milliseconds(stated.milliseconds))
            messages.append(f"readout {stated.milliseconds:g} ms from the {stated.source}")
        elif found is not None:
            sources["readout"] = f"camera database ({found.camera})"
            readout = ratio(Milliseconds(min(found.readout_ms, 1000.0 / fps)))
            messages.append(found.describe())
            if config.direction is None and found.direction != direction:
                direction, sources["direction"] = found.direction, sources["readout"]
        elif request == "auto" and estimate is not None:
            est = est or estimate(direction, fps)
            readout = float(est.readout)
            if est.reliable:
                sources["readout"] = _estimated(est)
                messages.append(f"readout estimated from the {_cue_words(est)}: "
                                f"{est.readout:.3f} of the frame interval (+-"
                                f"{est.uncertainty:.3f}, confidence {est.confidence:.2f})")
            else:
                sources["readout"] = "default: the footage could not tell it"
                messages.append(f"warning: the footage cannot tell the readout "
                                f"({est.note or 'its motion and lines do not change enough'}; "
                                f"confidence {est.confidence:.2f}); using {est.readout:g}")
        else:
            readout, sources["readout"] = 1.0, "default"
        checked = sources["readout"].startswith(("camera database", "lens profile"))
        if checked and estimate is not None and not is_pipe(path):
            # What the footage says, against the database or the profile.
            est = est or estimate(direction, fps)
            lo, hi = ((readout, readout) if found is None or 2 * found.agree > found.profiles
                      else (found.spread[0] * fps / 1000.0, found.spread[1] * fps / 1000.0))
            said = _disagreement(est, readout, lo, hi, sources["readout"])
            if said:
                sources["readout_check"] = "the footage disagrees"
                if request == "auto":  # the footage goes first
                    readout, sources["readout"] = float(est.readout), _estimated(est)
                    said += "; the footage's is used"
                else:
                    said += "; give --readout auto to use the footage's"
                messages.append(said)
            elif est.reliable:
                sources["readout_check"] = "the footage agrees"
    timing = SensorTiming(readout, direction, reference)  # type: ignore[arg-type]
    return ResolvedTiming(timing, fps, sources, tuple(messages), est)


def _estimated(est: Any) -> str:
    """Name the source of a readout estimated from the footage: its cue, its confidence."""
    return f"estimated from the {_cue_words(est)} (confidence {est.confidence:.2f})"


def _cue_words(est: Any) -> str:
    return {"motion": f"motion ({est.model} model)", "lines": "straight lines"}.get(
        est.cue, est.cue)


def _disagreement(est: Any, readout: float, lo: float, hi: float, source: str) -> str:
    """Warn where the footage's reliable estimate is outside a stated readout's range.

    The range is the stated value, or the database's where most of its profiles agree,
    else the spread of its profiles (it does not know better), widened by 5 % (profiles
    round); the estimate counts with two standard deviations either side.
    """
    if not est.reliable or not np.isfinite(est.uncertainty):
        return ""
    margin = 2.0 * est.uncertainty
    if lo * 0.95 - margin <= est.readout <= hi * 1.05 + margin:
        return ""
    rng = f"{lo:.3f}-{hi:.3f}" if hi - lo > 1e-3 else f"{readout:.3f}"
    return (f"warning: the {source} gives a readout of {rng} of the frame interval, but "
            f"the {_cue_words(est)} say {est.readout:.3f} (+-{est.uncertainty:.3f})")


def _database(config: CorrectionConfig, identified: str | None,
              size: tuple[int, int] | None, fps: float) -> tuple[CameraMatch | None, str]:
    """Return the camera database's match for the camera given, else the one the file names.

    A camera the user names must be in the database, once; one the file names vaguely
    (``GoPro``) is a hint: the cameras it fits are used where most of their profiles
    agree, else none. The second value is the warning that says so ('' if none).
    """
    name = config.camera or identified
    if not name:
        return None, ""
    w, h = size if size else (None, None)
    note = ""
    try:
        found = match(name, w, h, fps)
    except SettingsError:
        if config.camera:
            raise
        found = match(name, w, h, fps, family=True)
        if found is not None:
            lo, hi = found.spread
            if 2 * found.agree > found.profiles:
                note = (f"warning: the file names its camera only as {name!r}; the camera "
                        f"database's {found.camera}, {found.modes}, mostly agree on "
                        f"{found.readout_ms:g} ms, which is used (name the camera with "
                        "--camera to be sure)")
            else:
                note = (f"warning: the file names its camera only as {name!r}, and the "
                        f"camera database's {found.camera} disagree ({lo:.4g}-{hi:.4g} ms); "
                        "the default readout is used (name the camera with --camera, or "
                        "give --readout)")
                found = None
    if found is None and config.camera:
        raise SettingsError(f"camera {config.camera!r}: the camera database has no readout "
                            "for it (see `unjello cameras`)")
    if found is not None and found.readout_ms * fps / 1000.0 > 1.02:
        return None, note  # a profile of another frame rate, longer than this clip's frames
    return found, note


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
    pipe = is_pipe(src_p)
    if pipe and gyro:
        raise SettingsError("the gyro method reads its log beside the clip or in its file: "
                            "give it a file, not standard input")
    if pipe and config.readout == "auto":
        raise SettingsError("readout=auto reads the clip twice: give a file, or readout= "
                            "when piping")
    identified = (camera_of(src_p) if not pipe and given is None and not config.camera
                  and not config.lens_profile
                  and (config.readout in (None, "auto") or gyro or config.undistort)
                  else None)
    profile = read_lens_profile(config.lens_profile) if config.lens_profile else None
    known = (Lens(config.gyro.focal, config.gyro.distortion) if config.gyro.focal else None)
    resolved = resolve_timing(
        config, profile=profile, path=src_p, video_fps=source.info.fps,
        motion_timing=given.timing if given is not None else None,
        size=(source.info.width, source.info.height), identified=identified,
        estimate=lambda direction, fps: estimate_readout_file(src_p, direction=direction,
                                                              fps=fps, lens=known))
    gyro_log, own, report, distrust = None, None, {}, ""
    if gyro or config.undistort:
        config, lens = with_lens(config, config.camera or identified,
                                  (source.info.width, source.info.height), resolved.fps, profile)
        resolved = dataclasses.replace(resolved, messages=(*resolved.messages, *lens))
    if gyro:
        gyro_log, said, own = gyro_source(src_p, config.gyro)
        config, stated = _stated_by_log(config, src_p, resolved.timing.direction)
        if stated:
            said += f" ({stated})"
        resolved = dataclasses.replace(
            resolved, sources={**resolved.sources, "gyro": said},
            messages=(*resolved.messages, f"gyro: {said}"))
        report = {"source": said, "used": True, "explains": None, "why": ""}
        if own is not None and own.stabilised:
            distrust = (f"the camera stabilised the picture itself (stabilisation "
                        f"{own.stabilised!r}), so it no longer moves as the gyro says")
    return config, resolved, gyro_log, own, report, distrust


def _stated_by_log(config: CorrectionConfig, src: Path, direction: str
                   ) -> tuple[CorrectionConfig, str]:
    """Take what a log unjello wrote states (axes, clock, focal), unless it is given."""
    path = config.gyro.path
    if not path:
        try:
            path = str(find_gyro_log(src))
        except SettingsError:
            return config, ""
    if not is_gcsv(path):
        return config, ""
    stated = stated_calibration(read_gcsv(path)[1], direction)
    g = config.gyro
    fill = {k: v for k, v in stated.items()
            if getattr(g, k) is None or getattr(g, k) == "auto"}
    if not fill:
        return config, ""
    return (dataclasses.replace(config, gyro=dataclasses.replace(g, **fill)),  # type: ignore[arg-type]
            "written by unjello: its " + ", ".join(fill) + " as it states")


def database_readout(path: Path) -> str:
    """Say what the camera database knows of the camera a video file names ('' if nothing).

    One line naming the camera, the modes and the readout ``correct`` would take from it
    by itself (a folder, or a file that names no known camera: '').
    """
    if is_pipe(path) or Path(path).is_dir():
        return ""
    camera = camera_of(path)
    if not camera:
        return ""
    info = probe(path)
    found, vague = _database(CorrectionConfig(), camera, (info.width, info.height), info.fps)
    return found.describe() if found is not None else vague.removeprefix("warning: ")


def with_lens(config: CorrectionConfig, camera: str | None, size: tuple[int, int],
               fps: float, profile: LensProfile | None = None
               ) -> tuple[CorrectionConfig, tuple[str, ...]]:
    """Give the gyro method the lens a profile or the camera database knows.

    Only what is not given: ``focal`` and ``distortion`` of :class:`GyroConfig`.
    """
    g = config.gyro
    if g.focal is not None and g.distortion is not None:
        return config, ()
    lens, source = None, ""
    if config.lens_profile:
        profile = profile or read_lens_profile(config.lens_profile)
        lens, source = profile.lens(size[0]), f"lens profile {profile.name}"
    elif camera:
        try:
            found = match(camera, size[0], size[1], fps)
        except SettingsError:  # the file names several cameras: their lenses differ
            if config.camera:
                raise
            found = None
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


def describe(path: Path) -> dict[str, Any]:
    """Describe a video or a folder of frames as ``unjello probe`` prints it.

    Size, rate (and whether it varies), frames, duration, codec and format, rotation,
    audio, colour tags (a folder: size, frames, image format, channels, depth); the
    readout (fraction, ms, where from: ``None`` when only the default would be used),
    the scan direction and the lens (focal, fisheye k) that
    :func:`resolve_clip` finds for it.
    """
    folder = Path(path).is_dir()
    with FrameSource(path) as source:
        config, resolved, *_ = resolve_clip(CorrectionConfig(undistort=True), path, source)
        first = next(source.pictures(limit=1)) if folder else None
    said = resolved.sources["readout"]
    stated = not said.startswith("default")
    ms = resolved.timing.readout / resolved.fps * 1e3
    g = config.gyro
    lens = ({"focal": round(g.focal, 2), "distortion": list(g.distortion)}
            if g.focal is not None and g.distortion is not None else None)
    common = {"warnings": [m for m in resolved.messages if m.startswith("warning")],
              "readout": round(resolved.timing.readout, 6) if stated else None,
              "readout_ms": round(ms, 4) if stated else None,
              "readout_source": said if stated else None,
              "direction": resolved.timing.direction, "lens": lens}
    if first is not None:  # a folder of frames: no rate, codec, audio or tags of its own
        image = first.planes[0]
        return {"path": str(path), "folder": True, "width": image.shape[1],
                "height": image.shape[0], "frames": source.info.frames,
                "format": Path(str(first.name)).suffix.lstrip(".").lower(),
                "channels": image.shape[2] if image.ndim == 3 else 1,
                "bit_depth": int(image.dtype.itemsize * 8), "fps": None,
                "assumed_fps": resolved.fps, **common}
    info = probe(path)
    return {"path": str(path), "folder": False, "width": info.width, "height": info.height,
            "fps": round(info.fps, 4), "variable_frame_rate": variable_rate(path),
            "frames": info.frames, "duration": round(info.duration, 3), "codec": info.codec,
            "pix_fmt": info.pix_fmt, "bit_depth": info.bit_depth, "rotation": info.rotation,
            "audio_streams": info.audio_streams, **common,
            "color": {k: (str(v) if v is not None else None) for k, v in info.color.items()}}

