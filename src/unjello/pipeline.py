"""Streaming: source -> motion method -> warp -> sink, with bounded look-ahead.

One driver loop serves a video and a folder of frames alike: pictures come from a
:class:`~unjello.io.source.FrameSource`, go through a :class:`Corrector` (a motion method
and the per-frame warp), and leave through a :class:`~unjello.io.sink.PictureSink` and the
:class:`~unjello.exports.SideOutputs`. The motion method lags a fixed number of frames
behind the reader (two for the paper's method; the dense method's look-ahead, about 32
with vibration), so that many frames are held, however long the clip.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections import deque
from collections.abc import Callable, Iterable, MutableMapping, Sequence
from concurrent.futures import Executor
from pathlib import Path

import cv2
import numpy as np

from .clip import ResolvedTiming, resolve_clip
from .config import CorrectionConfig
from .errors import InputError, SettingsError
from .exports import SideOutputs
from .gyroflow import check_project, clip_project
from .gyrolog import GyroLog
from .heap import trim
from .io.codecs import check_output
from .io.sidecars import read_gyro
from .io.sink import PictureSink, check_new, check_paths
from .io.source import FrameSource, Picture
from .io.video import VIDEO_SUFFIXES, is_pipe
from .lens import Lens
from .motion.dense import DenseMethod
from .motion.fallback import GyroOrDense
from .motion.paper import PaperMethod
from .motion.replay import Replay
from .parallel import cores, frame_threads
from .stabilize import Stabilizer, track, tracking_copy
from .timing import SensorTiming, to_top_bottom
from .trajectory import FrameMotion, Trajectory
from .warp import PictureWarper

__all__ = ["Corrector", "correct_frames", "correct_video", "Progress"]

Progress = Callable[[int, int], None]


def _luma255(image: np.ndarray, max_value: float) -> np.ndarray:
    """Grey 0-255 of a plane or colour image; 8-bit luma is passed through as is."""
    if image.ndim == 2 and image.dtype == np.uint8 and max_value == 255:
        return image  # the methods convert after their own downscaling
    img = image
    if img.ndim == 3:
        rgb = img[..., :3]
        if rgb.dtype not in (np.uint8, np.uint16, np.float32):
            rgb = rgb.astype(np.float32)
        img = cv2.cvtColor(np.ascontiguousarray(rgb), cv2.COLOR_RGB2GRAY)
    return img.astype(np.float32) * np.float32(255.0 / max_value)


def _max_value(dtype: np.dtype) -> float:
    if np.issubdtype(dtype, np.integer):
        return float(np.iinfo(dtype).max)
    return 1.0


class Corrector:
    """Correct pictures one at a time with bounded look-ahead.

    A *picture* is a list of planes in coded orientation; the first is the luma (or a
    colour image) and drives the motion estimate; every plane is warped by the same
    displacement (:class:`~unjello.warp.PictureWarper`).

    Parameters
    ----------
    timing : SensorTiming
        Readout, direction and reference.
    config : CorrectionConfig
        Method and warp.
    max_value : float, optional
        White level of the first plane (255 for 8 bit, 1023 for 10 bit); default from
        the dtype.
    motion : Trajectory, optional
        Apply this motion (e.g. from ``motion_in``) instead of estimating it.
    fps : float
        Frame rate, for the gyro method.
    gyro_log : GyroLog, optional
        The gyro method's samples (default: read from ``config.gyro.path``).
    flows : mutable mapping, optional
        The dense method's flows between frame pairs, kept across correctors of the same
        frames (:class:`~unjello.motion.dense.DenseMethod`).
    only : set of int, optional
        Warp only these frames (by index from the first pushed); the others come back as
        they were read, with their motion (the preview wants one frame of a window).
    gyro_fallback : bool or str
        With the gyro method, what a gyro that does not fit the picture leads to
        (:class:`~unjello.motion.fallback.GyroOrDense`): False, an error; True, the
        dense method; a string, the dense method even if it fits (the reason).
    executor : concurrent.futures.Executor, optional
        Threads that measure the next frames' flows meanwhile
        (:func:`unjello.parallel.frame_threads`); the result is the same.
    workers : int
        The executor's threads (that many frame pairs are measured ahead).

    Attributes
    ----------
    method : str
        The method that measures the motion (``'dense'`` after a fallback).
    """

    def __init__(self, timing: SensorTiming, config: CorrectionConfig = CorrectionConfig(),
                 max_value: float | None = None, motion: Trajectory | None = None,
                 fps: float = 30.0, gyro_log: GyroLog | None = None,
                 flows: MutableMapping[tuple, tuple] | None = None,
                 only: set[int] | None = None, gyro_fallback: bool | str = False,
                 executor: Executor | None = None, workers: int = 2) -> None:
        self.timing = timing
        self.config = config
        self.max_value = max_value
        self._method: PaperMethod | DenseMethod | GyroOrDense | Replay
        if motion is not None:
            self._method = Replay(motion)
        elif config.method == "paper":
            self._method = PaperMethod(timing, config.paper)
        elif config.method == "gyro":
            if gyro_log is None:
                if not config.gyro.path:
                    raise InputError("the gyro method needs a gyro log: give gyro=FILE")
                gyro_log = read_gyro(config.gyro.path, config.gyro.layout, config.gyro.units)
            self._method = GyroOrDense(timing, gyro_log, config.gyro, config.dense, fps,
                                       flows, gyro_fallback)
        else:
            self._method = DenseMethod(timing, config.dense, flows, executor, workers)
        lens = None
        if config.undistort:
            if config.gyro.focal is None or config.gyro.distortion is None:
                raise SettingsError("undistort needs the lens: lens_profile=, camera= (a "
                                    "camera the database has a lens for), or focal= with "
                                    "distortion=")
            lens = Lens(config.gyro.focal, config.gyro.distortion)
        self.warp = PictureWarper(timing, config.warp, config.fill, undistort=lens)
        self.fps = fps
        self._stabilizer: Stabilizer | None = None
        # The previous frame's tracking copy, when stabilising.
        self._luma: tuple[np.ndarray, float] | None = None
        self._count = 0  # pictures pushed
        self._only = only
        self._held: deque[list[np.ndarray]] = deque()
        self._last: list[np.ndarray] | None = None  # the previous picture, as read
        self._last2: list[np.ndarray] | None = None  # and the one before it

    def push(self, planes: Sequence[np.ndarray], start: float
             ) -> list[tuple[list[np.ndarray], FrameMotion]]:
        """Add a picture whose first scanline starts at ``start`` (frame intervals).

        Returns
        -------
        list of (planes, FrameMotion)
            Pictures now corrected, in order.
        """
        planes = list(planes)
        mv = self.max_value or _max_value(planes[0].dtype)
        luma = _luma255(to_top_bottom(planes[0], self.timing.direction), mv)
        self._held.append(planes)
        motions = self._method.push(luma, start)
        if self.config.stabilize.enabled:
            if self._stabilizer is None:
                self._stabilizer = Stabilizer(self.config.stabilize, self.timing,
                                              (luma.shape[1], luma.shape[0]), self.fps)
            tracks = {}
            gyro = self.gyro
            if gyro is not None and gyro.method == "gyro" and gyro.agreement is not None:
                self._luma = None  # calibrated and used: its poses give every step
            else:
                small = tracking_copy(luma)
                if self._luma is not None:  # steps and roll, from points tracked across frames
                    tracks[self._count] = track(self._luma, small)
                self._luma = small
            motions = self._stabilizer.push(motions, tracks, self._poses(motions))
        self._count += 1
        return self._apply(motions)

    @property
    def pushed(self) -> int:
        """Pictures pushed so far (those read around a part of the clip too)."""
        return self._count

    @property
    def method(self) -> str:
        """The method that measures the motion (``'dense'`` after a gyro's fallback)."""
        if isinstance(self._method, GyroOrDense):
            return self._method.method
        return "replay" if isinstance(self._method, Replay) else self.config.method

    @property
    def vibration(self) -> float | None:
        """The dense method's detected vibration (its wobble), if ``auto`` switched it on."""
        return getattr(self._method, "wobble", None)

    @property
    def gyro(self) -> GyroOrDense | None:
        """The gyro method and what became of it (None for the other methods)."""
        return self._method if isinstance(self._method, GyroOrDense) else None

    def _poses(self, motions: list[FrameMotion]) -> dict[int, np.ndarray]:
        """Return the gyro's pose of each frame for the stabiliser (none from other methods)."""
        if self.gyro is None:
            return {}
        poses = {fm.index: self.gyro.pose(fm.start) for fm in motions}
        return {k: p for k, p in poses.items() if p is not None}

    def flush(self) -> list[tuple[list[np.ndarray], FrameMotion]]:
        """Correct the pictures still held at the end of the clip."""
        motions = self._method.flush()
        if self._stabilizer is not None:
            motions = (self._stabilizer.push(motions, poses=self._poses(motions))
                       + self._stabilizer.flush())
        return self._apply(motions)

    def _apply(self, motions: list[FrameMotion]) -> list[tuple[list[np.ndarray], FrameMotion]]:
        out = []
        for fm in motions:
            planes = self._held.popleft()
            around = {-2: self._last2, -1: self._last, 1: self._held[0] if self._held else None,
                      2: self._held[1] if len(self._held) > 1 else None}
            skip = self._only is not None and fm.index not in self._only
            if skip:
                out.append((planes, fm))
            else:
                warped = self.warp(planes, fm, around)
                out.append((warped, dataclasses.replace(fm, unseen=self.warp.unseen)))
            self._last2, self._last = self._last, planes
        return out


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
        Folder receiving one 16-bit STMap PNG per frame (see :mod:`unjello.exports`).
    gyroflow_out : path-like, optional
        Also write a Gyroflow project of the clip, ``NAME.gyroflow``, with its log
        ``NAME.gcsv`` (:func:`unjello.gyroflow.clip_project`), for the editors' plugins.
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
            emit(corrector.push(item.planes, item.start))
            if source.past_end and not any(p.keep for p in held):
                break  # the part is written: no need to read on
        else:
            emit(corrector.flush())
        traj.vibration = corrector.vibration
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
