"""Streaming pipeline: reader -> motion method -> warper -> writer.

Only :mod:`unjello.io` touches files; this module wires it to the pure-array core and
keeps memory bounded: the motion method lags a fixed number of frames behind the reader
(two for the paper's method, the dense method's look-ahead -- four at the start of a clip,
two after; about 32 with ``vibration``), so that many frames are held, however long the
clip.
"""

from __future__ import annotations

import dataclasses
import os
import shutil
import uuid
from collections import deque
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import cv2
import numpy as np

from .errors import InputError, OutputError, SettingsError
from .io.frames import list_frames, read_image, write_image
from .io.video import (
    VIDEO_SUFFIXES,
    EncodeOptions,
    ThreadedWriter,
    VideoReader,
    VideoWriter,
)
from .motion.dense import DenseConfig, DenseMethod
from .motion.gyro import GyroConfig, GyroMethod, load_method, write_gyro
from .motion.paper import PaperConfig, PaperMethod
from .readout import ReadoutEstimate, estimate_readout, stated_readout
from .timing import SensorTiming, from_top_bottom, parse_readout, to_top_bottom
from .trajectory import FrameMotion, Trajectory, TrajectoryWriter
from .warp import (
    Fill,
    WarpMode,
    apply_maps,
    field_maps,
    fill_from_neighbours,
    neighbour_sources,
    remap_maps,
    resample_displacement,
    resize_maps,
    splat,
)

__all__ = ["CorrectionConfig", "Corrector", "correct_frames", "correct_video", "correct",
           "Progress", "METHODS", "estimate_readout_file"]

METHODS = ("dense", "paper", "gyro")
Progress = Callable[[int, int], None]


@dataclass(frozen=True)
class CorrectionConfig:
    """How to correct: motion method, warp and hole filling.

    Parameters
    ----------
    method : {'dense', 'paper', 'gyro'}
        Motion estimation method: ``dense`` (per-pixel flow with a scanline-resolution
        camera trajectory, :mod:`unjello.motion.dense`), ``paper`` (Liang, Chang &
        Chen 2008, :mod:`unjello.motion.paper`) or ``gyro`` (a rotation per scanline from
        a gyroscope log, :mod:`unjello.motion.gyro`).
    warp : {'remap', 'splat'}
        Backward ``cv2.remap`` (fast) or the paper's forward splatting.
    fill : {'nearest', 'black'}
        Content of the area no scanline reaches.
    paper : PaperConfig
        Settings of the paper's stages.
    dense : DenseConfig
        Settings of the dense method.
    gyro : GyroConfig
        Settings of the gyro method (its log, and what is known of it).
    """

    method: Literal["dense", "paper", "gyro"] = "dense"
    warp: WarpMode = "remap"
    fill: Fill = "nearest"
    paper: PaperConfig = field(default_factory=PaperConfig)
    dense: DenseConfig = field(default_factory=DenseConfig)
    gyro: GyroConfig = field(default_factory=GyroConfig)

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise SettingsError(f"method must be one of {', '.join(METHODS)}")
        if self.warp not in ("remap", "splat"):
            raise SettingsError("warp must be 'remap' or 'splat'")
        if self.fill not in ("nearest", "black"):
            raise SettingsError("fill must be 'nearest' or 'black'")


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
    """Correct frames one at a time with bounded look-ahead.

    A *picture* is a list of planes in coded orientation; the first is the luma (or a
    colour image) and drives the motion estimate; every plane is warped by the same
    displacement scaled to its size (4:2:0 chroma included).

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
        Apply this motion (e.g. from ``--motion-in``) instead of estimating it.
    fps : float, optional
        Frame rate, for the gyro method (default ``config.gyro.fps``).
    """

    def __init__(self, timing: SensorTiming, config: CorrectionConfig = CorrectionConfig(),
                 max_value: float | None = None, motion: Trajectory | None = None,
                 fps: float | None = None) -> None:
        self.timing = timing
        self.config = config
        self.max_value = max_value
        self._method: PaperMethod | DenseMethod | GyroMethod | _Replay
        if motion is not None:
            self._method = _Replay(motion)
        elif config.method == "paper":
            self._method = PaperMethod(timing, config.paper)
        elif config.method == "gyro":
            self._method = load_method(timing, config.gyro, fps)
        else:
            self._method = DenseMethod(timing, config.dense)
        self._held: deque[list[np.ndarray]] = deque()
        self._maps: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = {}
        self._last: list[np.ndarray] | None = None  # the previous picture, as read

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
        return self._apply(self._method.push(luma, start))

    def flush(self) -> list[tuple[list[np.ndarray], FrameMotion]]:
        """Correct the pictures still held at the end of the clip."""
        return self._apply(self._method.flush())

    def _apply(self, motions: list[FrameMotion]) -> list[tuple[list[np.ndarray], FrameMotion]]:
        out = []
        for fm in motions:
            planes = self._held.popleft()
            around = {-1: self._last, 1: self._held[0] if self._held else None}
            out.append((self.warp(planes, fm, around), fm))
            self._last = planes
        return out

    def warp(self, planes: Sequence[np.ndarray], motion: FrameMotion,
             around: dict[int, list[np.ndarray] | None] | None = None) -> list[np.ndarray]:
        """Warp every plane of a picture by a frame's motion (per scanline or per pixel).

        ``around`` maps a frame offset (-1, 1) to that neighbour's planes: with a dense
        motion's ``neighbours`` flows, what this frame does not see is taken from them
        (:func:`unjello.warp.fill_from_neighbours`) instead of repeating the edge.
        """
        d = self.timing.direction
        ref = to_top_bottom(planes[0], d)
        h, w = ref.shape[:2]
        out = []
        maps = field_maps(motion.field, frame=(h, w)) if motion.field is not None else None
        sized: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = {}
        sources: list[tuple[list[np.ndarray], np.ndarray]] = []
        parts: dict[tuple[int, int], list] = {}
        if around and self.config.fill == "nearest":
            for k, flow in motion.neighbours:
                pic = around.get(k)
                if pic is not None:
                    sources.append((pic, flow))
        for i, plane in enumerate(planes):
            tb = to_top_bottom(plane, d)
            ph, pw = tb.shape[:2]
            if maps is None and self.config.warp == "splat":
                res, _ = splat(tb, self._plane_displacement(motion, ph, pw, h, w),
                               fill=self.config.fill)
            else:
                if (ph, pw) not in sized:  # U and V share their maps
                    sized[(ph, pw)] = resize_maps(*maps, ph, pw) if maps is not None else (
                        remap_maps(self._plane_displacement(motion, ph, pw, h, w), pw,
                                   out=self._buffers(ph, pw)))
                res = apply_maps(tb, sized[(ph, pw)], fill=self.config.fill)
                if maps is not None and sources:
                    if (ph, pw) not in parts:
                        parts[(ph, pw)] = neighbour_sources(
                            sized[(ph, pw)], [flow for _, flow in sources], maps)
                    res = fill_from_neighbours(
                        res, parts[(ph, pw)],
                        [to_top_bottom(pic[i], d) for pic, _ in sources])
            out.append(from_top_bottom(res, d))
        return out

    def _buffers(self, h: int, w: int) -> tuple[np.ndarray, np.ndarray]:
        """Map buffers for planes of ``h x w``, reused from frame to frame."""
        if (h, w) not in self._maps:
            self._maps[(h, w)] = (np.empty((h, w), np.float32), np.empty((h, w), np.float32))
        return self._maps[(h, w)]

    @staticmethod
    def _plane_displacement(motion: FrameMotion, ph: int, pw: int, h: int, w: int
                            ) -> np.ndarray:
        """Return the per-scanline displacement for a plane of ``ph x pw`` (4:2:0 chroma)."""
        if (ph, pw) == (h, w):
            return motion.displacement
        return resample_displacement(motion.displacement, ph, pw / w, ph / h)


class _Replay:
    """A "method" that hands back the frames of a stored Trajectory, in order."""

    def __init__(self, traj: Trajectory) -> None:
        self._frames = {f.index: f for f in traj.frames}
        self._n = 0

    def push(self, frame: np.ndarray, start: float) -> list[FrameMotion]:
        fm = self._frames.get(self._n)
        if fm is None:
            raise InputError(f"the motion file has no frame {self._n}")
        if fm.displacement.shape[0] != frame.shape[0]:
            raise InputError("the motion file was made for frames of another size")
        self._n += 1
        return [fm]

    def flush(self) -> list[FrameMotion]:
        return []


def correct_frames(
    frames: Iterable[np.ndarray],
    timing: SensorTiming | None = None,
    *,
    config: CorrectionConfig = CorrectionConfig(),
    starts: Sequence[float] | None = None,
) -> tuple[list[np.ndarray], Trajectory]:
    """Correct a sequence of images held in memory.

    Parameters
    ----------
    frames : iterable of ndarray of shape (H, W[, C])
        Consecutive rolling-shutter frames in coded orientation.
    timing : SensorTiming, optional
        Readout, direction and reference (default: readout 1, top-bottom, middle).
    config : CorrectionConfig
        Method and warp.
    starts : sequence of float, optional
        Start time of each frame in frame intervals (variable frame rate); default
        ``0, 1, 2, ...``.

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
    corr = Corrector(timing, config)
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
    return out, traj


def _temp_path(dst: Path) -> Path:
    return dst.with_name(f".{dst.stem}.unjello-{uuid.uuid4().hex[:8]}{dst.suffix}")


def _check_paths(src: Path, dst: Path, overwrite: bool) -> None:
    if not src.exists():
        raise InputError(f"{src}: no such file or folder")
    if dst.resolve() == src.resolve() or (dst.exists() and os.path.samefile(src, dst)):
        raise OutputError(f"output {dst} is the input; choose another name")
    if src.is_file() and dst.is_dir():
        raise OutputError(f"{dst} is a folder; give the output video a file name")
    if src.is_dir() and dst.resolve().is_relative_to(src.resolve()):
        raise OutputError(f"output {dst} is inside the input folder; choose another place")
    if dst.exists() and not overwrite:
        raise OutputError(f"{dst} exists; pass -y to overwrite it")
    parent = dst.parent if str(dst.parent) else Path(".")
    if not parent.exists():
        raise OutputError(f"{parent}: output folder does not exist")
    if not os.access(parent, os.W_OK):
        raise OutputError(f"{parent}: output folder is not writable")


def _frames_for_estimate(src: Path, max_frames: int) -> tuple[list[np.ndarray], list[float],
                                                              float | None]:
    """First frames (luma or image) and their start times, for readout estimation."""
    frames: list[np.ndarray] = []
    starts: list[float] = []
    if src.is_dir():
        for i, f in enumerate(list_frames(src)[:max_frames]):
            frames.append(read_image(f))
            starts.append(float(i))
        return frames, starts, None
    with VideoReader(src) as reader:
        info = reader.info
        tb = float(info.time_base)
        first = None
        for kind, item, pts in reader.packets():
            if kind != "video":
                continue
            planes = item  # type: ignore[assignment]
            luma = planes[0]  # type: ignore[index]
            if info.bit_depth > 8:
                luma = (luma >> 2).astype(np.uint8)
            if first is None and pts is not None:
                first = pts
            starts.append((pts - first) * tb * info.fps if pts is not None and first is not None
                          else float(len(frames)))
            frames.append(luma)
            if len(frames) >= max_frames:
                break
        return frames, starts, info.fps


def estimate_readout_file(src: str | os.PathLike, *, direction: str = "top-bottom",
                          max_frames: int = 60, fallback: float = 1.0) -> ReadoutEstimate:
    """Estimate the readout ratio of a video or image folder from its motion.

    Parameters
    ----------
    src : path-like
        Video file or folder of frames.
    direction : str
        Scan direction.
    max_frames : int
        Frames analysed from the start.
    fallback : float
        Readout returned when the motion cannot tell.

    Returns
    -------
    ReadoutEstimate
        See :func:`unjello.readout.estimate_readout`.
    """
    src = Path(src)
    if not src.exists():
        raise InputError(f"{src}: no such file or folder")
    frames, starts, _ = _frames_for_estimate(src, max_frames)
    if not frames:
        raise InputError(f"{src}: no frames")
    return estimate_readout(frames, direction=direction, starts=starts, fallback=fallback)


def _gyro_sidecar(src: Path) -> Path:
    """Return the gyro log beside ``src``: ``NAME.gyro.csv`` or ``NAME.gyro.txt``.

    This is how ``--method gyro`` without ``--gyro``, and ``batch``, find each clip's log.
    """
    base = src.with_suffix("") if src.is_file() else src
    for ext in (".gyro.csv", ".gyro.txt"):
        cand = base.with_name(base.name + ext)
        if cand.is_file():
            return cand
    raise SettingsError(f"the gyro method needs a gyro log: pass --gyro FILE or put "
                        f"{base.name}.gyro.csv beside {src.name}")


def _resolve_readout(src: Path, readout: float | str | None, direction: str,
                     log: Callable[[str], None] | None) -> float | str:
    """Turn ``None`` (not given) and ``'auto'`` into a readout, saying where it came from.

    ``None``: the readout stated by a sidecar or the file's metadata, else 1.0. ``'auto'``:
    the stated one, else the estimate from the motion. Anything else is used as given.
    """
    is_auto = isinstance(readout, str) and readout.strip().lower() == "auto"
    if readout is not None and not is_auto:
        return readout
    stated = stated_readout(src)
    if stated is not None:
        if log:
            log(f"readout {stated.milliseconds:g} ms from the {stated.source}")
        return f"{stated.milliseconds}ms"
    if not is_auto:
        return 1.0
    est = estimate_readout_file(src, direction=direction)
    if log:
        if est.reliable:
            log(f"readout estimated from the motion: {est.readout:.3f} of the frame interval "
                f"(confidence {est.confidence:.2f}, {est.model} motion model)")
        else:
            log(f"warning: the motion is too weak or too uniform to estimate the readout "
                f"(confidence {est.confidence:.2f}); using {est.readout:g}")
    return est.readout


def correct_video(
    src: str | os.PathLike,
    dst: str | os.PathLike,
    *,
    readout: float | str | None = None,
    direction: str = "top-bottom",
    reference: str = "middle",
    config: CorrectionConfig = CorrectionConfig(),
    encode: EncodeOptions = EncodeOptions(),
    overwrite: bool = False,
    motion_out: str | os.PathLike | None = None,
    progress: Progress | None = None,
    log: Callable[[str], None] | None = None,
    motion_in: str | os.PathLike | None = None,
    preview: str | os.PathLike | None = None,
    stmap: str | os.PathLike | None = None,
) -> Trajectory:
    """Correct a video file, or a folder of frames, into ``dst``.

    Parameters
    ----------
    src : path-like
        A video file PyAV can decode, or a folder of images (sorted by name).
    dst : path-like
        Output video file, or (for a folder input) output folder receiving the corrected
        frames under the same names.
    readout : float or str, optional
        Readout as a fraction of the frame interval, ``"15.7ms"``, or ``"auto"``. Not
        given: the readout a sidecar or the file's metadata states
        (:func:`unjello.readout.stated_readout`), else 1.0. ``"auto"``: the stated one,
        else estimated from the motion (:func:`estimate_readout_file`).
    direction, reference : str
        See :class:`~unjello.timing.SensorTiming`.
    config : CorrectionConfig
        Method and warp.
    encode : EncodeOptions
        Codec, CRF and preset of the output video.
    overwrite : bool
        Replace an existing ``dst``.
    motion_out : path-like, optional
        Also write the estimated trajectory as JSON.
    progress : callable, optional
        Called as ``progress(done, total)`` after each frame (``total`` may be 0).
    log : callable, optional
        Receives one-line messages (what ``auto`` found, warnings).
    motion_in : path-like, optional
        Apply a trajectory written by ``motion_out`` instead of estimating the motion
        (its readout, direction and reference are used).
    preview : path-like, optional
        Also write a side-by-side video: input left, corrected right.
    stmap : path-like, optional
        Folder receiving one 16-bit STMap PNG per frame (see :mod:`unjello.exports`).

    Returns
    -------
    Trajectory
        The estimated motion, per scanline (dense per-pixel fields are not kept in
        memory for a whole clip; ``motion_out`` stores them).

    Raises
    ------
    InputError, OutputError, SettingsError
        On bad input, an existing output without ``overwrite``, or a bad option. Nothing
        is written then; the output appears only when complete (temp file + rename).
    """
    src_p, dst_p = Path(src), Path(dst)
    _check_paths(src_p, dst_p, overwrite)
    for extra in (preview, stmap, motion_out):
        if extra is not None and Path(extra).exists() and not overwrite:
            raise OutputError(f"{extra} exists; pass -y to overwrite it")
    given = Trajectory.load(motion_in) if motion_in is not None else None
    extras_motion = Path(motion_out) if motion_out is not None else None
    if given is not None:
        readout, direction, reference = (given.timing.readout, given.timing.direction,
                                         given.timing.reference)
    else:
        readout = _resolve_readout(src_p, readout, direction, log)
    if config.method == "gyro" and not config.gyro.path and given is None:
        config = dataclasses.replace(config, gyro=dataclasses.replace(
            config.gyro, path=str(_gyro_sidecar(src_p))))
    extras = _Extras(preview, stmap, overwrite, encode, extras_motion)
    if src_p.is_dir():
        traj = _correct_folder(src_p, dst_p, readout, direction, reference, config, progress,
                               given, extras)
    else:
        traj = _correct_file(src_p, dst_p, readout, direction, reference, config, encode,
                             progress, given, extras)
    if log and len(traj) == 1:
        log("warning: a single frame has no motion to measure; copied through unchanged")
    return traj


correct = correct_video


class _Extras:
    """Optional side outputs written while correcting: preview video and STMaps."""

    def __init__(self, preview: str | os.PathLike | None, stmap: str | os.PathLike | None,
                 overwrite: bool, encode: EncodeOptions, motion_out: Path | None = None
                 ) -> None:
        self.motion_out = motion_out
        self._motion: TrajectoryWriter | None = None
        self.preview = Path(preview) if preview is not None else None
        self.stmap = Path(stmap) if stmap is not None else None
        self.overwrite = overwrite
        self.encode = encode
        self._stmap_tmp: Path | None = None
        self._sink: FrameSink | None = None
        self._writer: VideoWriter | None = None
        self._preview_tmp: Path | None = None

    def start(self, fps: float, traj: Trajectory, reader: VideoReader | None = None) -> None:
        if self.motion_out is not None:
            self._motion = TrajectoryWriter(self.motion_out, traj)
        if self.stmap is not None:
            self._stmap_tmp = _temp_path(self.stmap)
            self._stmap_tmp.mkdir()
        if self.preview is not None:
            if reader is not None:
                info = reader.info
                self._preview_tmp = _temp_path(self.preview)
                self._writer = VideoWriter(
                    self._preview_tmp, size=(2 * info.width + 4, info.height), fps=info.fps,
                    time_base=info.time_base, pix_fmt=reader.work_format, options=self.encode,
                    rotation=info.rotation, color=info.color)
            else:
                self._sink = FrameSink(self.preview, fps, self.overwrite, self.encode)

    def frame(self, before: list[np.ndarray], after: list[np.ndarray], fm: FrameMotion,
              timing: SensorTiming, pts: int | None = None) -> None:
        if self._motion is not None:
            self._motion.write(fm)
        if self._stmap_tmp is not None:
            from .exports import write_stmap

            h, w = before[0].shape[:2]
            write_stmap(self._stmap_tmp, fm, timing, (w, h))
        if self._writer is not None:
            self._writer.write(_side_by_side_planes(before, after), pts)
        elif self._sink is not None:
            from .demo import side_by_side

            self._sink.write(side_by_side(_rgb8(before[0]), _rgb8(after[0]), ("input", "unjello")))

    def finish(self) -> None:
        if self._motion is not None:
            self._motion.close()
        if self._writer is not None and self._preview_tmp is not None and self.preview:
            self._writer.close()
            _replace(self._preview_tmp, self.preview)
        if self._sink is not None:
            self._sink.close()
        if self._stmap_tmp is not None and self.stmap is not None:
            _replace(self._stmap_tmp, self.stmap)

    def abort(self) -> None:
        if self._motion is not None:
            self._motion.abort()
        if self._writer is not None:
            self._writer.abort()
        if self._sink is not None:
            self._sink.abort()
        for tmp in (self._preview_tmp, self._stmap_tmp):
            if tmp is not None and tmp.is_dir():
                shutil.rmtree(tmp, ignore_errors=True)
            elif tmp is not None and tmp.exists():
                tmp.unlink()


def _light(fm: FrameMotion) -> FrameMotion:
    """Drop the per-pixel field of a frame kept for the whole clip (flat memory)."""
    return fm if fm.field is None else dataclasses.replace(fm, field=None, neighbours=())


def _replace(tmp: Path, dst: Path) -> None:
    if dst.is_dir():
        shutil.rmtree(dst)
    elif dst.exists():
        dst.unlink()
    os.replace(tmp, dst)


def _rgb8(img: np.ndarray) -> np.ndarray:
    if img.ndim == 2:
        img = np.repeat(img[..., None], 3, axis=2)
    if img.dtype != np.uint8:
        img = (img.astype(np.float64) * 255.0 / np.iinfo(img.dtype).max).astype(np.uint8)
    return np.ascontiguousarray(img[..., :3])


def _side_by_side_planes(before: list[np.ndarray], after: list[np.ndarray]) -> list[np.ndarray]:
    """Input and output planes next to each other with a 4-pixel white divider."""
    out = []
    w0 = before[0].shape[1]
    for i, (a, b) in enumerate(zip(before, after, strict=True)):
        div = max(1, 4 * a.shape[1] // w0)
        white = np.iinfo(a.dtype).max if i == 0 else (np.iinfo(a.dtype).max + 1) // 2
        bar = np.full((a.shape[0], div) + a.shape[2:], white, dtype=a.dtype)
        out.append(np.hstack([a, bar, b]))
    return out


def _describe(img: np.ndarray) -> str:
    """``WxH, N channel(s)`` of an image, for messages."""
    channels = img.shape[2] if img.ndim == 3 else 1
    return f"{img.shape[1]}x{img.shape[0]}, {channels} channel{'s' if channels > 1 else ''}"


def _correct_folder(src: Path, dst: Path, readout: float | str, direction: str, reference: str,
                    config: CorrectionConfig, progress: Progress | None,
                    given: Trajectory | None = None, extras: _Extras | None = None
                    ) -> Trajectory:
    files = list_frames(src)
    if isinstance(readout, str) and readout.strip().endswith("ms"):
        raise SettingsError("a readout in milliseconds needs a video (a folder has no fps)")
    timing = SensorTiming(parse_readout(readout), direction, reference)  # type: ignore[arg-type]
    first = read_image(files[0])
    if min(first.shape[:2]) < 16:
        raise InputError(f"{src}: frames of {first.shape[1]}x{first.shape[0]} are too small")

    def images() -> Iterable[np.ndarray]:
        for f in files:
            img = read_image(f)
            if img.shape != first.shape:
                raise InputError(f"{f.name}: {_describe(img)} differs from the first frame's "
                                 f"{_describe(first)} (a folder must hold one clip's frames)")
            yield img

    tmp = _temp_path(dst)
    tmp.mkdir()
    extras = extras or _Extras(None, None, False, EncodeOptions())
    try:
        corr = Corrector(timing, config, motion=given)
        traj = Trajectory(timing, (first.shape[1], first.shape[0]),
                          method=given.method if given else config.method)
        names = iter(files)
        inputs: deque[np.ndarray] = deque()
        done = 0
        extras.start(30.0, traj)

        def emit(items: list[tuple[list[np.ndarray], FrameMotion]]) -> None:
            nonlocal done
            for planes, fm in items:
                write_image(tmp / next(names).name, planes[0])
                extras.frame([inputs.popleft()], planes, fm, timing)
                traj.frames.append(_light(fm))
                done += 1
                if progress:
                    progress(done, len(files))

        for i, img in enumerate(images()):
            inputs.append(img)
            emit(corr.push([img], float(i)))
        emit(corr.flush())
        extras.finish()
        _replace(tmp, dst)
    except BaseException:
        extras.abort()
        raise
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return traj


def _correct_file(src: Path, dst: Path, readout: float | str, direction: str, reference: str,
                  config: CorrectionConfig, encode: EncodeOptions,
                  progress: Progress | None, given: Trajectory | None = None,
                  extras: _Extras | None = None) -> Trajectory:
    with VideoReader(src) as reader:
        info = reader.info
        timing = SensorTiming(parse_readout(readout, info.fps), direction,  # type: ignore[arg-type]
                              reference)  # type: ignore[arg-type]
        if info.width < 16 or info.height < 16:
            raise InputError(f"{src}: frames of {info.width}x{info.height} are too small")
        max_value = 1023.0 if info.bit_depth == 10 else 255.0
        corr = Corrector(timing, config, max_value=max_value, motion=given, fps=info.fps)
        traj = Trajectory(timing, (info.width, info.height),
                          method=given.method if given else config.method)
        tmp = _temp_path(dst)
        writer = ThreadedWriter(VideoWriter.like(tmp, reader, encode))
        extras = extras or _Extras(None, None, False, encode)
        pts_queue: deque[int | None] = deque()
        inputs: deque[list[np.ndarray]] = deque()
        tb = float(info.time_base)
        first_pts: int | None = None
        n = 0
        try:
            extras.start(info.fps, traj, reader)

            def emit(items: list[tuple[list[np.ndarray], FrameMotion]]) -> None:
                for planes, fm in items:
                    pts = pts_queue.popleft()
                    writer.write(planes, pts)
                    extras.frame(inputs.popleft(), planes, fm, timing, pts)
                    traj.frames.append(_light(fm))
                    if progress:
                        progress(writer.frames_written, info.frames)

            for kind, item, pts in reader.packets():
                if kind == "audio":
                    writer.copy_audio(item)  # type: ignore[arg-type]
                    continue
                if first_pts is None and pts is not None:
                    first_pts = pts
                start = ((pts - first_pts) * tb * info.fps if pts is not None
                         and first_pts is not None else float(n))
                pts_queue.append(pts)
                inputs.append(item)  # type: ignore[arg-type]
                emit(corr.push(item, start))  # type: ignore[arg-type]
                n += 1
            if n == 0:
                raise InputError(f"{src}: the video has no frames")
            emit(corr.flush())
            writer.close()
            extras.finish()
        except BaseException:
            writer.abort()
            extras.abort()
            if tmp.exists():
                tmp.unlink()
            raise
    os.replace(tmp, dst)
    return traj




class FrameSink:
    """Write RGB frames to a video file or a folder of PNGs, atomically.

    Parameters
    ----------
    path : path-like
        ``*.mp4`` (or another video suffix) for a video, anything else for a folder
        that receives ``frame_00000.png`` ...
    fps : float
        Frame rate of a video.
    overwrite : bool
        Replace an existing output.
    encode : EncodeOptions
        Encoder settings of a video.
    """

    def __init__(self, path: str | os.PathLike, fps: float = 30.0, overwrite: bool = False,
                 encode: EncodeOptions = EncodeOptions()) -> None:
        self.path = Path(path)
        if self.path.exists() and not overwrite:
            raise OutputError(f"{self.path} exists; pass -y to overwrite it")
        parent = self.path.parent
        if not parent.exists():
            raise OutputError(f"{parent}: output folder does not exist")
        self.is_video = self.path.suffix.lower() in VIDEO_SUFFIXES
        self._tmp = _temp_path(self.path)
        self._fps, self._encode = fps, encode
        self._writer: VideoWriter | None = None
        self._n = 0
        if not self.is_video:
            self._tmp.mkdir()

    def write(self, image: np.ndarray) -> None:
        """Append one frame."""
        if self.is_video:
            if self._writer is None:
                h, w = image.shape[:2]
                if w % 2 or h % 2:
                    raise OutputError("video frames need an even width and height")
                self._writer = VideoWriter(self._tmp, size=(w, h), fps=self._fps,
                                           options=self._encode)
            self._writer.write_rgb(image)
        else:
            write_image(self._tmp / f"frame_{self._n:05d}.png", image)
        self._n += 1

    def close(self) -> None:
        """Finish and move the output into place."""
        if self._writer is not None:
            self._writer.close()
        if self.path.exists():
            if self.path.is_dir():
                shutil.rmtree(self.path)
            else:
                self.path.unlink()
        os.replace(self._tmp, self.path)

    def abort(self) -> None:
        """Drop the partial output."""
        if self._writer is not None:
            self._writer.abort()
        if self._tmp.is_dir():
            shutil.rmtree(self._tmp, ignore_errors=True)
        elif self._tmp.exists():
            self._tmp.unlink()

    def __enter__(self) -> FrameSink:
        return self

    def __exit__(self, exc_type: object, *rest: object) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()


def read_source(path: str | os.PathLike) -> tuple[Callable[[int], np.ndarray] | np.ndarray,
                                                     float | None]:
    """Open a simulation source: an image, or a video read frame by frame in order.

    Returns
    -------
    scene : ndarray or callable
        The image, or ``scene(n)`` returning video frame ``n`` (sequential access; the
        last frame repeats past the end).
    fps : float or None
        The video's frame rate.
    """
    p = Path(path)
    if not p.exists():
        raise InputError(f"{p}: no such file")
    if p.suffix.lower() not in VIDEO_SUFFIXES:
        return read_image(p), None
    reader = VideoReader(p)
    frames = reader.rgb_frames()
    state: dict = {"n": -1, "img": None}

    def scene(n: int) -> np.ndarray:
        while state["n"] < n:
            nxt = next(frames, None)
            if nxt is None:
                if state["img"] is None:
                    raise InputError(f"{p}: the video has no frames")
                break
            state["n"] += 1
            state["img"] = nxt
        return state["img"]

    return scene, reader.info.fps


def simulate_clip(source: str | os.PathLike, rolling_out: str | os.PathLike,
                  truth_out: str | os.PathLike, *, motion: str = "pan",
                  timing: SensorTiming = SensorTiming(), frames: int = 30,
                  fps: float | None = None, size: tuple[int, int] | None = None,
                  speed: float = 8.0, amplitude: float = 1.0, exposure: float = 0.0,
                  overwrite: bool = False, truth_motion: str | os.PathLike | None = None,
                  encode: EncodeOptions = EncodeOptions(),
                  gyro_out: str | os.PathLike | None = None) -> Trajectory:
    """Render a rolling-shutter clip and its global-shutter truth to files.

    Parameters
    ----------
    source : path-like
        A still image (panned over) or a global-shutter video.
    rolling_out, truth_out : path-like
        Outputs: video files (``.mp4`` ...) or folders of PNG frames.
    motion : str
        A motion name of :data:`unjello.simulate.MOTIONS` or a JSON file.
    timing : SensorTiming
        Readout, direction, reference.
    frames : int
        Number of frames.
    fps : float, optional
        Frame rate (default: the source video's, else 30).
    size : tuple of int, optional
        Output ``(width, height)``.
    speed, amplitude, exposure : float
        See :class:`unjello.simulate.Motion` and :func:`unjello.simulate.simulate`.
    overwrite : bool
        Replace existing outputs.
    truth_motion : path-like, optional
        Where to write the true trajectory (default ``<truth_out>.motion.json``).
    encode : EncodeOptions
        Encoder settings of video outputs.
    gyro_out : path-like, optional
        Also write a 400 Hz gyroscope log of the motion (CSV: time in s from the first
        frame, then rad/s about x, y, z), as from a lens of 8 times the frame's width
        (:func:`unjello.simulate.gyro_samples`).

    Returns
    -------
    Trajectory
        The true per-scanline motion.
    """
    from .simulate import gyro_samples, motion_from_spec, simulate

    if gyro_out is not None and Path(gyro_out).exists() and not overwrite:
        raise OutputError(f"{gyro_out} exists; pass -y to overwrite it")

    scene, src_fps = read_source(source)
    fps = float(fps or src_fps or 30.0)
    mot = motion_from_spec(motion, fps=fps, speed=speed, amplitude=amplitude, n_frames=frames)
    truth_motion = Path(truth_motion or f"{truth_out}.motion.json")
    traj: Trajectory | None = None
    with FrameSink(rolling_out, fps, overwrite, encode) as rs_sink, \
            FrameSink(truth_out, fps, overwrite, encode) as gs_sink:
        for sf in simulate(scene, mot, timing, frames, size=size, exposure=exposure):
            if traj is None:
                h, w = sf.rolling.shape[:2]
                traj = Trajectory(timing, (w, h), method="truth")
            rs_sink.write(sf.rolling)
            gs_sink.write(sf.truth)
            traj.frames.append(sf.motion)
    assert traj is not None
    traj.save(truth_motion)
    if gyro_out is not None:
        t, rates = gyro_samples(mot, 8.0 * traj.size[0], frames / fps)
        tmp = _temp_path(Path(gyro_out))
        write_gyro(tmp, t, rates)
        _replace(tmp, Path(gyro_out))
    return traj


def read_frames(path: str | os.PathLike) -> Iterable[np.ndarray]:
    """Yield the frames of a video (RGB) or an image folder, in order."""
    p = Path(path)
    if not p.exists():
        raise InputError(f"{p}: no such file or folder")
    if p.is_dir():
        for f in list_frames(p):
            yield read_image(f)
    else:
        with VideoReader(p) as reader:
            yield from reader.rgb_frames()


def evaluate(output: str | os.PathLike, truth: str | os.PathLike, *,
             motion: str | os.PathLike | None = None,
             true_motion: str | os.PathLike | None = None, margin: int = 0) -> list[dict]:
    """Score corrected frames against global-shutter truth, frame by frame.

    Parameters
    ----------
    output, truth : path-like
        Videos or image folders with the same number of frames.
    motion, true_motion : path-like, optional
        Estimated and true trajectories (JSON); with both, the per-scanline displacement
        error is reported too (``true_motion`` defaults to ``<truth>.motion.json`` when
        that file exists).
    margin : int
        Pixels cropped from every side before PSNR/SSIM.

    Returns
    -------
    list of dict
        ``frame``, ``psnr``, ``ssim`` and, with trajectories, ``displacement_error`` and
        ``uncorrected_error`` (px).
    """
    from .metrics import displacement_error, psnr, ssim

    if true_motion is None and Path(f"{truth}.motion.json").exists():
        true_motion = Path(f"{truth}.motion.json")
    est = Trajectory.load(motion) if motion else None
    tru = Trajectory.load(true_motion) if true_motion else None
    rows = []
    for i, (a, b) in enumerate(zip(read_frames(output), read_frames(truth), strict=False)):
        if a.shape[:2] != b.shape[:2]:
            raise InputError(f"frame {i}: output {a.shape[1]}x{a.shape[0]} and truth "
                             f"{b.shape[1]}x{b.shape[0]} differ in size")
        row = {"frame": i, "psnr": psnr(a, b, margin), "ssim": ssim(a, b, margin)}
        if tru is not None and i < len(tru.frames):
            row["uncorrected_error"] = displacement_error(None, tru.frames[i])
            if est is not None and i < len(est.frames):
                row["displacement_error"] = displacement_error(est.frames[i], tru.frames[i])
        rows.append(row)
    if not rows:
        raise InputError("no frames to compare")
    return rows
