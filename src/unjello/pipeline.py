"""Streaming: source -> motion method -> warp -> sink, with bounded look-ahead.

One driver loop serves a video and a folder of frames alike: pictures come from a
:class:`~unjello.io.source.FrameSource`, go through a :class:`Corrector` (a motion method
and the per-frame warp), and leave through a :class:`~unjello.io.sink.PictureSink` and the
:class:`~unjello.exports.outputs.SideOutputs`. The motion method lags a fixed number of frames
behind the reader (two for the paper's method; the dense method's look-ahead, about 32
with vibration), so that many frames are held, however long the clip.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections import deque
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path

import numpy as np

from .clip import ResolvedTiming, resolve_clip
from .config import CorrectionConfig
from .corrector import Corrector
from .errors import InputError, SettingsError
from .exports.gyroflow import check_project, clip_project
from .exports.outputs import SideOutputs
from .io.codecs import check_output
from .io.sink import PictureSink, check_new, check_paths
from .io.source import FrameSource, Picture
from .io.video import VIDEO_SUFFIXES, is_pipe
from .run.heap import trim
from .run.parallel import cores, frame_threads
from .timing import SensorTiming
from .trajectory import FrameMotion, Trajectory

__all__ = ["Corrector", "correct_frames", "correct_video", "Progress"]

Progress = Callable[[int, int], None]


def correct_frames(
    frames: Iterable[np.ndarray],
    timing: SensorTiming | None = None,
    *,
    config: CorrectionConfig = CorrectionConfig(),
    starts: Sequence[float] | None = None,
    fps: float = 30.0,
) -> tuple[list[np.ndarray], Trajectory]:
    """Correct a sequence of images held in memory.

    Parameters
    ----------
    frames : iterable of ndarray of shape (H, W[, C])
        Consecutive rolling-shutter frames in coded orientation.
    timing : SensorTiming, optional
        Readout, direction and reference (default: readout 1, top-bottom, middle).
    config : CorrectionConfig
        Method and warp (its timing settings are not read here: ``timing`` is).
    starts : sequence of float, optional
        Start time of each frame in frame intervals (variable frame rate); default
        ``0, 1, 2, ...``.
    fps : float
        Frame rate, for the gyro method.

    Returns
    -------
    corrected : list of ndarray
        The corrected frames, same shapes and dtypes.
    trajectory : Trajectory
        The estimated per-scanline motion.

    Examples
    --------
    >>> from unjello.simulate import Motion, simulate
    >>> from skimage import data
    >>> sim = list(simulate(data.camera(), Motion("pan", speed=6), SensorTiming(1.0), 4,
    ...                     size=(160, 120)))
    >>> out, traj = correct_frames([s.rolling for s in sim])
    >>> err = np.mean([np.abs(f.displacement - s.motion.displacement).mean()
    ...                for f, s in zip(traj.frames, sim)])
    >>> bool(err < 0.2)
    True
    """
    timing = timing or SensorTiming()
    corr = Corrector(timing, config, fps=fps)
    out: list[np.ndarray] = []
    traj: Trajectory | None = None
    for i, img in enumerate(frames):
        if traj is None:
            traj = Trajectory(timing, (img.shape[1], img.shape[0]), method=config.method)
        start = float(starts[i]) if starts is not None else float(i)
        for planes, fm in corr.push([img], start):
            out.append(planes[0])
            traj.frames.append(fm)
    if traj is None:
        raise InputError("no frames to correct")
    for planes, fm in corr.flush():
        out.append(planes[0])
        traj.frames.append(fm)
    traj.vibration = corr.vibration
    traj.stretches = corr.close_stretches()
    return out, traj


def correct_video(
    src: str | os.PathLike,
    dst: str | os.PathLike,
    config: CorrectionConfig = CorrectionConfig(),
    *,
    overwrite: bool = False,
    motion_out: str | os.PathLike | None = None,
    motion_in: str | os.PathLike | None = None,
    preview: str | os.PathLike | None = None,
    stmap: str | os.PathLike | None = None,
    gyroflow_out: str | os.PathLike | None = None,
    progress: Progress | None = None,
    log: Callable[[str], None] | None = None,
    on_timing: Callable[[ResolvedTiming], None] | None = None,
    on_gyro: Callable[[dict], None] | None = None,
) -> Trajectory:
    """Correct a video file, or a folder of frames, into ``dst``.

    Parameters
    ----------
    src : path-like
        A video file PyAV can decode, or a folder of images (sorted by name).
    dst : path-like
        Output video file, or (for a folder input) output folder receiving the corrected
        frames under the same names.
    config : CorrectionConfig
        Timing, method, warp and encoder (:mod:`unjello.config`; readout, direction,
        reference and frame rate are decided by :func:`unjello.clip.resolve_timing`).
    overwrite : bool
        Replace existing outputs.
    motion_out : path-like, optional
        Also write the estimated trajectory as JSON.
    motion_in : path-like, optional
        Apply a trajectory written by ``motion_out`` instead of estimating the motion
        (its readout, direction and reference are used).
    preview : path-like, optional
        Also write a side-by-side video: input left, corrected right.
    stmap : path-like, optional
        Folder receiving one 16-bit STMap PNG per frame (see :mod:`unjello.exports.outputs`).
    gyroflow_out : path-like, optional
        Also write a Gyroflow project of the clip, ``NAME.gyroflow``, with its log
        ``NAME.gcsv`` (:func:`unjello.exports.gyroflow.clip_project`), for the editors' plugins.
    progress : callable, optional
        Called as ``progress(done, total)`` after each frame (``total`` may be 0).
    log : callable, optional
        Receives one-line messages (where the readout came from, warnings).
    on_timing : callable, optional
        Called once with the :class:`~unjello.clip.ResolvedTiming`: the readout,
        direction, reference and frame rate used, and where each came from.
    on_gyro : callable, optional
        With the gyro method, called once at the end with what became of the gyro:
        ``{"source": str, "used": bool, "explains": float or None, "why": str}``. The
        camera's own gyro (read from the file) that does not explain the picture's motion
        -- a camera on a gimbal, a picture the camera stabilised itself -- is not used:
        the dense method measures the motion instead, and ``log`` says so. A gyro log
        given or found beside the clip that does not fit is an error.

    Returns
    -------
    Trajectory
        The estimated motion, per scanline (dense per-pixel fields are not kept in
        memory for a whole clip; ``motion_out`` stores them).

    Raises
    ------
    InputError, OutputError, SettingsError
        On bad input, an existing output without ``overwrite``, or a bad setting.
        Nothing is written then; the outputs appear only when complete.
    """
    src_p, dst_p = Path(src), Path(dst)
    if not is_pipe(src) and not src_p.exists():
        raise InputError(f"{src_p}: no such file or folder")
    if is_pipe(dst) and config.encode.format is None:  # standard output: NUT by default
        config = config.with_options(format="nut")
    check_paths(src_p, dst_p, overwrite)
    if is_pipe(src) or is_pipe(dst) or not src_p.is_dir() or dst_p.suffix.lower() in \
            VIDEO_SUFFIXES:  # a video out: codec, profile, container agree
        check_output(config.encode.codec, config.encode.profile, dst_p, config.encode.format)
    side = SideOutputs(motion_out, stmap, preview, config.encode)
    for extra in side.paths:
        check_new(extra, overwrite)
    if gyroflow_out is not None:
        check_project(gyroflow_out, is_pipe(src), config.span.whole, overwrite)
    if motion_in is not None and not config.span.whole:
        raise SettingsError("motion_in= replays the motion of a whole clip: leave out start= "
                            "and duration=, or cut the clip first")
    given = Trajectory.load(motion_in) if motion_in is not None else None
    with FrameSource(src_p) as source:
        config, resolved, gyro_log, own, report, distrust = resolve_clip(
            config, src_p, source, given)
        for message in resolved.messages:
            if log:
                log(message)
        if on_timing:
            on_timing(resolved)
        traj = Trajectory(resolved.timing, (source.info.width, source.info.height),
                          method=given.method if given else config.method, fps=resolved.fps,
                          source="" if is_pipe(src) else str(src_p))
        workers = config.threads or cores()
        with frame_threads(workers) as pool:
            corrector = Corrector(resolved.timing, config, max_value=source.info.max_value,
                                  motion=given, fps=resolved.fps, gyro_log=gyro_log,
                                  gyro_fallback=distrust or own is not None, executor=pool,
                                  workers=workers)
            sink = PictureSink(dst_p, source, config.encode, resolved.fps)
            _stream(source, sink, corrector, side, traj, resolved, progress, config)
        resized, size = source.resized
        if log and resized:
            log(f"warning: the picture size changed part-way ({size[0]}x{size[1]}): "
                f"{resized} frame(s) scaled to the first frame's "
                f"{source.info.width}x{source.info.height}, as ffmpeg does; the motion "
                "starts again there")
        if log and source.restarts:
            log(f"warning: the video's timestamps started over {source.restarts} time(s) "
                "(streams joined end to end): carried on, as ffmpeg's concatenation does; "
                "the motion starts again there")
        if log and source.damaged:
            log(f"warning: {source.damaged} frame(s) of the input were damaged (the decoder "
                "patched over the errors); they and their corrections may show blocks")
    if report and corrector.gyro is not None:
        if corrector.gyro.fallback:
            report.update(used=False, why=corrector.gyro.fallback)
        share = corrector.gyro.agreement
        report["explains"] = None if share is None or not np.isfinite(share) else round(share, 3)
        if not report["used"] and log:
            log(f"warning: the camera's own gyro was not used: {report['why']}; the dense "
                "method measured the motion instead")
        if on_gyro:
            on_gyro(report)
    if log and corrector.pushed == 1:
        log("warning: a single frame has no motion to measure; copied through unchanged")
    if gyroflow_out is not None:
        clip_project(traj, gyroflow_out, clip=src_p, config=config, fps=resolved.fps,
                     rotation=source.reader.info.rotation if source.reader else 0.0,
                     gyro=corrector.gyro, overwrite=overwrite, log=log)
    return traj


def _stream(source: FrameSource, sink: PictureSink, corrector: Corrector, side: SideOutputs,
            traj: Trajectory, resolved: ResolvedTiming, progress: Progress | None,
            config: CorrectionConfig = CorrectionConfig()) -> None:
    """Run the driver loop: every picture in, corrected out, side outputs beside it.

    With a part of the clip (``config.span``), the pictures read around it go through
    the motion method but are not written, and reading stops once the part's last
    picture is out (its look-ahead read).
    """
    held: deque[Picture] = deque()
    span = config.span
    total = source.info.frames  # for the progress bar (0: unknown)
    if not span.whole:
        part = span.length(resolved.fps, total or math.inf)
        total = int(part) if math.isfinite(part) else 0
    zero = 0.0  # the first picture written's start: the output's time zero

    def emit(items: list[tuple[list[np.ndarray], FrameMotion]]) -> None:
        nonlocal zero
        if corrector.gyro is not None:  # before the motion JSON's header is written
            traj.method = corrector.method
        for planes, fm in items:
            picture = held.popleft()
            if not picture.keep:  # read around the part asked for: its motion only
                continue
            if not span.whole:  # numbered and timed from the part's start
                if not traj.frames:
                    zero = fm.start
                fm = dataclasses.replace(fm, index=len(traj), start=fm.start - zero)
            sink.write(picture, planes)
            side.frame(picture.planes, planes, fm, resolved.timing, picture.pts)
            traj.frames.append(_light(fm))
            if progress:
                progress(sink.frames_written, total)
            trim(sink.frames_written)  # the freed memory back (glibc keeps it)

    # Ahead of a part: the stabiliser's smoothing window, or a second, for the motion.
    before = math.ceil(resolved.fps * max(1.0, 2.0 * config.stabilize.smoothness))
    try:
        side.start(source, traj, resolved.fps)
        for item in source.items(resolved.fps, span, before):
            if not isinstance(item, Picture):
                sink.copy_audio(item)
                continue
            held.append(item)
            emit(corrector.push(item.planes, item.start, item.joined or None))
            if source.past_end and not any(p.keep for p in held):
                break  # the part is written: no need to read on
        else:
            emit(corrector.flush())
        traj.vibration = corrector.vibration
        traj.stretches = corrector.close_stretches()
        sink.close()
        side.finish()
    except BaseException:
        sink.abort()
        side.abort()
        raise


def _light(fm: FrameMotion) -> FrameMotion:
    """Drop the per-pixel field of a frame kept for the whole clip (flat memory)."""
    return fm if fm.field is None else dataclasses.replace(fm, field=None, front=(),
                                                           neighbours=())
