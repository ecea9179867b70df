"""Video files with PyAV: decode to planes in coded orientation, encode, copy audio.

Frames are handed to the core as their planar YUV planes (``Y``, ``U``, ``V``) in the
coded (sensor) orientation, never converted to RGB: no colour-matrix round trip, the
bit depth is kept (8 or 10 bit), and the writer encodes the same planes. Other pixel
formats are converted to ``yuv420p`` (or ``yuv420p10le`` above 8 bit). The writer keeps
every frame's pts in the input's time base (variable frame rate survives), copies every
audio stream packet by packet (no re-encode), and sets the display rotation and colour
tags of the input.
"""

from __future__ import annotations

import errno
import os
import sys
from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from fractions import Fraction
from pathlib import Path
from typing import Any

import av
import numpy as np

from ..errors import InputError, OutputError, SettingsError, cannot_write
from .codecs import encoder_options, keeps_full_range, output_format

__all__ = ["VideoInfo", "VideoReader", "VideoWriter", "probe",
           "EncodeOptions", "variable_rate", "VIDEO_SUFFIXES", "metadata_tags", "PIPE",
           "is_pipe", "PIPE_FORMATS"]

#: The name of standard input (as an input) or standard output (as an output).
PIPE = "-"
#: Containers a pipe may carry out: NUT (pts and audio kept; the default) or raw frames.
PIPE_FORMATS = ("nut", "yuv4mpegpipe", "matroska", "mpegts")


def is_pipe(path: str | os.PathLike | None) -> bool:
    """Return whether ``path`` names standard input or output (``-``)."""
    return path is not None and str(path) == PIPE

VIDEO_SUFFIXES = (".mp4", ".mov", ".mkv", ".avi", ".m4v", ".webm", ".mts", ".m2ts")

_PLANAR = {"yuv420p", "yuv422p", "yuv444p", "yuv420p10le", "yuv422p10le", "yuv444p10le"}
#: FFmpeg's code of the full colour range ("PC", 0-255; limited, "TV", 16-235, is 1).
FULL = 2


@dataclass(frozen=True)
class VideoInfo:
    """What a video file holds (see :func:`probe`)."""

    path: str
    width: int
    height: int
    fps: float
    time_base: Fraction
    frames: int
    duration: float
    pix_fmt: str
    bit_depth: int
    rotation: int
    audio_streams: int
    codec: str
    color: dict = field(default_factory=dict)


@dataclass(frozen=True)
class EncodeOptions:
    """Encoder settings of the output video (libx264, CRF 18 by default).

    ``crf`` and ``preset`` are libx264's and libx265's; ``profile`` is ProRes's
    (``proxy`` ... ``4444xq``) or DNxHR's (``dnxhr_lb`` ... ``dnxhr_444``;
    :mod:`unjello.io.codecs`); ``format`` the container of a pipe (:data:`PIPE_FORMATS`;
    a file's is its suffix's).
    """

    codec: str = "libx264"
    crf: int = 18
    preset: str = "medium"
    profile: str | None = None
    format: str | None = None

    def __post_init__(self) -> None:
        if not 0 <= self.crf <= 51:
            raise SettingsError(f"crf must be 0 to 51, got {self.crf}")


def _open(path: str | os.PathLike) -> av.container.InputContainer:
    if is_pipe(path):
        try:
            return av.open(sys.stdin.buffer, "r")
        except (av.FFmpegError, ValueError) as exc:
            raise InputError("standard input: not a video stream (empty, or not NUT, "
                             f"Matroska, MPEG-TS or y4m: {exc.__class__.__name__})") from None
    p = Path(path)
    if not p.exists():
        raise InputError(f"{p}: no such file or folder")
    if p.is_dir():
        raise InputError(f"{p}: is a folder, not a video")
    try:
        c = av.open(str(p), "r")
    except (av.FFmpegError, UnicodeDecodeError, ValueError):
        raise InputError(f"{p}: {_unreadable(p)}") from None
    if not c.streams.video:
        c.close()
        raise InputError(f"{p}: has no video stream")
    return c


#: How video containers begin: (offset, bytes).
_SIGNATURES = ((4, b"ftyp"), (4, b"moov"), (4, b"mdat"), (4, b"wide"), (4, b"free"),
               (0, b"\x1a\x45\xdf\xa3"), (0, b"RIFF"), (0, b"nut/multimedia"),
               (0, b"YUV4MPEG2"), (0, b"\x00\x00\x01\xba"), (0, b"OggS"), (0, b"FLV"))


def _unreadable(p: Path) -> str:
    """Say why a file that FFmpeg cannot open is not a video: empty, cut short, or not one."""
    size = p.stat().st_size
    if size == 0:
        return "the file is empty"
    with p.open("rb") as f:
        head = f.read(16)
    if any(head[at:at + len(sig)] == sig for at, sig in _SIGNATURES) or (
            head[:1] == b"\x47" and size >= 189):  # MPEG-TS sync bytes
        return (f"a video file cut short or damaged ({size:,} bytes; its index cannot be "
                "read: was it copied or recorded to the end?)")
    return "not a video file (no container FFmpeg knows)"


def _work_format(pix_fmt: str | None) -> str:
    """Return the planar format the core works in: the input's where it is planar YUV.

    FFmpeg's ``yuvj`` formats are the same planes at full range: they are read as the
    plain format, and the range travels as a tag (``VideoReader.full_range``), so that no
    conversion ever squeezes the levels.
    """
    if pix_fmt and pix_fmt.startswith("yuvj"):
        pix_fmt = "yuv" + pix_fmt[4:]
    if pix_fmt in _PLANAR:
        return pix_fmt
    if pix_fmt and ("10" in pix_fmt or "12" in pix_fmt or "16" in pix_fmt):
        return "yuv420p10le"
    return "yuv420p"


_UNSPECIFIED = {"color_range": 0, "colorspace": 2, "color_primaries": 2, "color_trc": 2}


def _tagged(color: dict) -> bool:
    """Whether colour tags say anything (a range, matrix, primaries or transfer)."""
    return any(v is not None and int(v) != _UNSPECIFIED.get(k, 2) for k, v in color.items())


#: The errors that say the file system refused a write (not the encoder).
_WRITE_ERRORS = {errno.EACCES, errno.EPERM, errno.EROFS, errno.ENOSPC, errno.EDQUOT,
                 errno.ENOENT, errno.ENOTDIR, errno.EFBIG, errno.EIO}


def _range_of(full: bool) -> str:
    return "JPEG" if full else "MPEG"


def probe(path: str | os.PathLike) -> VideoInfo:
    """Describe a video file.

    Raises
    ------
    InputError
        If it is missing, not a video, or has no video stream.
    """
    c = _open(path)
    try:
        return _describe(c, path, first_frame=True)
    finally:
        c.close()


def _describe(c: av.container.InputContainer, path: str | os.PathLike, first_frame: bool
              ) -> VideoInfo:
    """Describe an open video; ``first_frame``: decode it for its rotation (not a pipe's)."""
    vs = c.streams.video[0]
    cc = vs.codec_context
    if cc is None or not cc.width or not cc.height:
        raise InputError(f"{path}: its video stream cannot be decoded (damaged or "
                         "truncated file?)")
    rate = vs.average_rate or vs.guessed_rate or vs.base_rate or Fraction(30)
    rotation = 0
    frames = vs.frames
    color = {k: getattr(cc, k, None) for k in
             ("color_range", "colorspace", "color_primaries", "color_trc")}
    if str(cc.pix_fmt).startswith("yuvj"):
        color["color_range"] = FULL
    try:
        for fr in c.decode(video=0) if first_frame else ():
            rotation = int(fr.rotation or 0)
            if fr.color_range == FULL or fr.format.name.startswith("yuvj"):
                color["color_range"] = FULL
            break
    except av.FFmpegError:
        pass
    duration = float(c.duration / av.time_base) if c.duration else 0.0
    fmt = _work_format(cc.pix_fmt)
    return VideoInfo(
        path=str(path), width=cc.width, height=cc.height, fps=float(rate),
        time_base=vs.time_base or Fraction(1, 90000), frames=int(frames or 0),
        duration=duration, pix_fmt=str(cc.pix_fmt), bit_depth=10 if "10" in fmt else 8,
        rotation=rotation, audio_streams=len(c.streams.audio), codec=cc.name, color=color,
    )


def metadata_tags(path: str | os.PathLike) -> dict[str, str]:
    """Container and stream metadata tags of a media file (empty if unreadable)."""
    try:
        with av.open(str(path)) as c:
            tags = dict(c.metadata)
            for s in c.streams:
                tags.update(s.metadata)
            return tags
    except (av.FFmpegError, OSError, ValueError, UnicodeDecodeError):
        return {}


def variable_rate(path: str | os.PathLike, max_frames: int = 300) -> bool:
    """Whether the first frames' pts steps differ by more than 1 % (variable frame rate)."""
    c = _open(path)
    try:
        pts = []
        for packet in c.demux(c.streams.video[0]):
            if packet.pts is not None:
                pts.append(packet.pts)
            if len(pts) >= max_frames:
                break
    except av.FFmpegError:
        return False
    finally:
        c.close()
    steps = np.diff(np.sort(np.asarray(pts, dtype=np.float64)))
    steps = steps[steps > 0]
    return bool(steps.size > 1 and (steps.max() - steps.min()) > 0.01 * np.median(steps))


def frame_planes(frame: av.VideoFrame) -> list[np.ndarray]:
    """Copy the planes of a planar YUV frame into arrays (no padding)."""
    dtype = np.uint16 if "10" in frame.format.name else np.uint8
    out = []
    for p in frame.planes:
        a = np.frombuffer(memoryview(p), dtype=dtype)
        a = a.reshape(p.height, p.line_size // a.itemsize)[:, :p.width]
        out.append(a.copy())
    return out


def planes_frame(planes: list[np.ndarray], fmt: str) -> av.VideoFrame:
    """Build a frame of pixel format ``fmt`` from plane arrays."""
    h, w = planes[0].shape
    frame = av.VideoFrame(w, h, fmt)
    for p, a in zip(frame.planes, planes, strict=True):  # one copy, into the frame's buffer
        buf = np.frombuffer(memoryview(p), dtype=a.dtype)
        buf.reshape(p.height, p.line_size // a.itemsize)[:, :p.width] = a
    return frame


class VideoReader:
    """Iterate a video's frames as planes, and its audio packets for copying.

    Parameters
    ----------
    path : path-like
        Input video.

    Examples
    --------
    Use as a context manager; iterate :meth:`packets` to get ``('video', planes, pts)``
    and ``('audio', packet, None)`` items in file order.
    """

    def __init__(self, path: str | os.PathLike) -> None:
        probed = None if is_pipe(path) else probe(path)
        self._c = _open(path)
        # Standard input is read once: described from its header.
        self.info: VideoInfo = (probed if probed is not None
                                else _describe(self._c, "standard input", first_frame=False))
        self._vs = self._c.streams.video[0]
        self._vs.thread_type = "AUTO"
        self.work_format = _work_format(self._vs.codec_context.pix_fmt)
        #: Full-range levels (0-255, as GoPros and many phones write): kept as they are.
        self.full_range = self.info.color.get("color_range") == FULL
        #: Frames the decoder flagged as damaged (errors it concealed) so far.
        self.damaged = 0
        #: Frames decoded at another picture size than the first, scaled to it (as ffmpeg
        #: scales a stream whose size changes to its output's), and the first such size.
        self.resized = 0
        self.other_size: tuple[int, int] | None = None
        #: Whether the frame last yielded was decoded at another size than the one before.
        self.size_changed = False
        self._decoded: tuple[int, int] | None = None
        self.audio = list(self._c.streams.audio)

    def __enter__(self) -> VideoReader:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Close the file."""
        self._c.close()

    def packets(self, audio: bool = True) -> Iterator[tuple[str, object, int | None]]:
        """Yield decoded video frames (as planes) and raw audio packets in file order.

        Parameters
        ----------
        audio : bool
            Also the audio packets.

        Raises
        ------
        InputError
            If the stream is corrupt beyond what the decoder can skip.
        """
        try:
            for packet in self._c.demux(self._vs, *(self.audio if audio else ())):
                if packet.stream.type == "audio":
                    if packet.dts is not None:
                        yield "audio", packet, None
                    continue
                for frame in packet.decode():
                    assert isinstance(frame, av.VideoFrame)
                    if frame.is_corrupt:
                        self.damaged += 1
                    yield "video", self._planes(frame), frame.pts
        except av.FFmpegError as exc:
            raise InputError(f"{self.info.path}: decoding failed ({exc})") from None

    def start_pts(self) -> int:
        """Return the pts of the video's first frame (its stream's start time, else 0)."""
        return int(self._vs.start_time or 0)

    def seek(self, pts: int) -> None:
        """Go to the keyframe at or before ``pts`` (the video stream's time base)."""
        self._c.seek(pts, stream=self._vs, backward=True, any_frame=False)

    def packet_times(self) -> tuple[list[int], set[int]]:
        """Return the pts of every video packet, and those of the keyframes (none decoded).

        Raises
        ------
        InputError
            Packets without timestamps (a raw stream).
        """
        pts: list[int] = []
        keys: set[int] = set()
        for packet in self._c.demux(self._vs):
            if packet.pts is None:
                if packet.size:
                    raise InputError(f"{self.info.path}: its frames carry no timestamps")
                continue
            pts.append(packet.pts)
            if packet.is_keyframe:
                keys.add(packet.pts)
        return pts, keys

    def rgb_frames(self) -> Iterator[np.ndarray]:
        """Yield every video frame as an RGB uint8 array (coded orientation)."""
        try:
            for frame in self._c.decode(self._vs):
                yield frame.to_ndarray(format="rgb24")
        except av.FFmpegError as exc:
            raise InputError(f"{self.info.path}: decoding failed ({exc})") from None

    def _planes(self, frame: av.VideoFrame) -> list[np.ndarray]:
        name = frame.format.name
        size = (frame.width, frame.height)
        self.size_changed = self._decoded is not None and size != self._decoded
        self._decoded = size
        if size != (self.info.width, self.info.height):
            self.resized += 1
            self.other_size = self.other_size or size
            r = _range_of(self.full_range)
            frame = frame.reformat(width=self.info.width, height=self.info.height,
                                   format=self.work_format, interpolation="BICUBIC",
                                   src_color_range=r, dst_color_range=r)
        elif name != self.work_format and _work_format(name) != self.work_format:
            # Another layout (NV12, RGB ...): converted, the levels' range kept.
            r = _range_of(self.full_range)
            frame = frame.reformat(format=self.work_format, src_color_range=r,
                                   dst_color_range=r)
        return frame_planes(frame)


class _StdoutPipe:
    """Standard output as the file PyAV writes into, cut off once the output is aborted.

    PyAV writes no trailer into a file that says it is ``closed``, so an aborted output
    never blocks on a full pipe whose reader stopped reading (a stop signal would hang).
    The bytes go to the unbuffered stream beneath ``sys.stdout`` where there is one: none
    are left in Python's buffer for the exit to flush into a pipe nobody reads (a run
    stopped by Ctrl-C once hung there).
    """

    closed = False
    _raw: Any = None  # where the bytes go: the raw stream, else the buffer

    def write(self, data: bytes) -> int:
        if self.closed:
            return len(data)
        if self._raw is None:
            buffer = sys.stdout.buffer
            buffer.flush()  # what was written before, in order
            self._raw = getattr(buffer, "raw", None) or buffer
        view, done = memoryview(data), 0
        while done < len(view):
            n = self._raw.write(view[done:])
            if n is None:  # a non-blocking stream with no room: nothing more to do here
                break
            done += n
        return done


class VideoWriter:
    """Encode frames to a video file, optionally copying audio streams unchanged.

    Parameters
    ----------
    path : path-like
        Output file (written as is; atomicity is the caller's temp-and-rename).
    size : tuple of int
        ``(width, height)`` of the frames.
    fps : float
        Nominal frame rate.
    time_base : Fraction, optional
        Time base of the pts given to :meth:`write` (default ``1/fps``).
    pix_fmt : str
        Pixel format of the planes given to :meth:`write`.
    options : EncodeOptions
        Codec, CRF and preset.
    rotation : int
        Display rotation to tag the stream with (degrees).
    color : dict, optional
        ``color_range``, ``colorspace``, ``color_primaries``, ``color_trc`` to tag.
    audio : sequence of av streams
        Input audio streams whose packets :meth:`copy_audio` will mux.
    """

    def __init__(self, path: str | os.PathLike, *, size: tuple[int, int], fps: float,
                 time_base: Fraction | None = None, pix_fmt: str = "yuv420p",
                 options: EncodeOptions = EncodeOptions(), rotation: int = 0,
                 color: dict | None = None, audio: tuple = ()) -> None:
        self._fmt = _work_format(pix_fmt)
        full = (color or {}).get("color_range") == FULL
        self._range = _range_of(full)  # the planes' levels
        # ... and the file's: full range kept where the codec's files can say so.
        self._out_range = _range_of(full and keeps_full_range(options.codec))
        color = {**(color or {}), **({"color_range": 1} if full and self._out_range == "MPEG"
                                     else {})}
        rate = Fraction(fps).limit_denominator(100000)
        self._time_base = time_base or Fraction(1, 1) / rate
        self._path = path
        try:
            if not is_pipe(path):  # created here, so that a folder we cannot write says so
                Path(path).touch()
            self._pipe = _StdoutPipe() if is_pipe(path) else None
            self._c = (av.open(self._pipe, "w", format=options.format or "nut")
                       if self._pipe else av.open(str(path), "w", format=options.format))
        except OSError as exc:  # PyAV's errors are OSErrors too
            raise cannot_write(path, exc) from None
        except ValueError as exc:
            raise OutputError(f"{path}: cannot create output ({exc})") from None
        self._numbered = "yuv4mpeg" in self._c.format.name
        if self._numbered:  # raw frames: no audio, no timestamps (one a frame interval)
            audio = ()
            self._time_base = Fraction(1, 1) / rate
        if (options.codec == "rawvideo" and self._c.format.name == "nut"
                and _tagged(color or {})):
            # NUT has no field for colour tags and raw frames carry none: the frames go as
            # lossless H.264, whose stream carries them (the pixels are the same).
            options = replace(options, codec="libx264", crf=0, preset="ultrafast")
        try:
            vs = self._c.add_stream(options.codec, rate=rate)
            assert isinstance(vs, av.video.stream.VideoStream)
        except (av.FFmpegError, ValueError, AssertionError) as exc:
            self._c.close()
            if not is_pipe(path):
                Path(path).unlink(missing_ok=True)
            raise OutputError(f"unknown or unavailable codec {options.codec!r} ({exc})") from None
        self._out_fmt = output_format(options.codec, options.profile, pix_fmt)
        self._codec = options.codec
        vs.width, vs.height = size
        vs.pix_fmt = self._out_fmt
        vs.time_base = self._time_base
        vs.codec_context.time_base = self._time_base
        vs.thread_type = "AUTO"
        vs.options = encoder_options(options.codec, options.crf, options.preset,
                                     options.profile)  # type: ignore[assignment]
        for k, v in color.items():
            if v is not None:
                try:
                    setattr(vs.codec_context, k, v)
                except (AttributeError, ValueError, TypeError):
                    pass
        if rotation:
            vs.set_display_rotation(rotation)
        self._vs = vs
        self._audio = {a.index: self._c.add_stream_from_template(a) for a in audio}
        self.frames_written = 0

    @classmethod
    def like(cls, path: str | os.PathLike, reader: VideoReader,
             options: EncodeOptions = EncodeOptions()) -> VideoWriter:
        """Make a writer with the reader's size, rate, format, rotation, colour and audio."""
        info = reader.info
        return cls(path, size=(info.width, info.height), fps=info.fps, time_base=info.time_base,
                   pix_fmt=reader.work_format, options=options, rotation=info.rotation,
                   color=info.color, audio=tuple(reader.audio))

    def write(self, planes: list[np.ndarray], pts: int | None) -> None:
        """Encode one frame given as planes, at ``pts`` (in the writer's time base)."""
        self._encode(planes_frame(planes, self._fmt), pts)

    def write_rgb(self, image: np.ndarray, pts: int | None = None) -> None:
        """Encode one RGB (uint8) frame; ``pts`` defaults to the frame count."""
        frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(image[..., :3]), format="rgb24")
        self._encode(frame.reformat(format=self._fmt, dst_color_range=self._range),
                     self.frames_written if pts is None else pts)

    def _encode(self, frame: av.VideoFrame, pts: int | None) -> None:
        if frame.format.name != self._out_fmt or self._range != self._out_range:
            # The codec's own format (ProRes: 10-bit) or range (ProRes: limited).
            frame = frame.reformat(format=self._out_fmt, src_color_range=self._range,
                                   dst_color_range=self._out_range)
        if self._out_range == "JPEG":
            frame.color_range = FULL
        frame.pts = self.frames_written if self._numbered else pts
        frame.time_base = self._time_base
        try:
            for packet in self._vs.encode(frame):
                self._c.mux(packet)
        except av.FFmpegError as exc:
            raise self._refused(exc) from None
        self.frames_written += 1

    def _refused(self, exc: av.FFmpegError) -> OutputError:
        """Say why the encoder could not be opened or fed.

        A size or format it refuses, or a file the system would not write (its folder,
        the disk).
        """
        if isinstance(exc, OSError) and exc.errno in _WRITE_ERRORS:
            return cannot_write(self._path, exc)
        vs = self._vs
        return OutputError(f"the {self._codec} encoder refused {vs.width}x{vs.height} "
                           f"{self._out_fmt} ({exc.__class__.__name__}: {exc.strerror})")

    def copy_audio(self, packet: av.Packet) -> None:
        """Mux an audio packet from the reader unchanged."""
        out = self._audio.get(packet.stream.index)
        if out is not None:
            packet.stream = out
            try:  # the first packet muxed opens every stream's encoder
                self._c.mux(packet)
            except av.FFmpegError as exc:
                raise self._refused(exc) from None

    def close(self) -> None:
        """Flush the encoder and close the file."""
        for packet in self._vs.encode():
            self._c.mux(packet)
        self._c.close()

    def cut(self) -> None:
        """Write nothing more into a pipe (safe from any thread; a file is left as it is)."""
        if self._pipe is not None:
            self._pipe.closed = True

    def abort(self) -> None:
        """Close without flushing (the caller deletes the file; a pipe gets nothing more)."""
        self.cut()  # no trailer into a pipe whose reader may have stopped reading
        try:
            self._c.close()
        except av.FFmpegError:
            pass
