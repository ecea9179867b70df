"""A frame source: a video file or a folder of images, frame by frame with start times.

This is the one place that turns a video's presentation timestamps into the start times
the motion methods use (frame intervals from the first frame, :mod:`unjello.timing`).
A video yields its pictures as planes in coded orientation (YUV, 8 or 10 bit), in file
order with its audio packets; a folder yields its images (RGB, RGBA or grey), sorted by
name.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..timing import ClipSpan
from .frames import list_frames, read_image
from .video import VideoReader, is_pipe

__all__ = ["Picture", "SourceInfo", "FrameSource", "read_frames"]

_MIN_SIZE = 16


@dataclass(frozen=True)
class SourceInfo:
    """What a source is, before any frame is decoded.

    Attributes
    ----------
    path : Path
    is_video : bool
    width, height : int
        Frame size in coded orientation.
    fps : float or None
        The video's nominal frame rate; None for a folder (it states none).
    frames : int
        Number of frames (0: unknown).
    max_value : float
        White level of the first plane (255 for 8 bit, 1023 for 10-bit video).
    time_base : Fraction or None
        The video's time base.
    """

    path: Path
    is_video: bool
    width: int
    height: int
    fps: float | None
    frames: int
    max_value: float
    time_base: Fraction | None = None


@dataclass(frozen=True)
class Picture:
    """One frame as read: its planes, and where it sits in time.

    Attributes
    ----------
    planes : list of ndarray
        A video's planes (luma first), or a folder's single image.
    start : float
        Start time of its first scanline, in frame intervals from the first frame.
    pts : int or None
        A video frame's presentation timestamp (kept on output).
    name : str or None
        A folder image's file name (kept on output).
    keep : bool
        Whether it is in the part of the clip asked for (:meth:`FrameSource.items`);
        False for a frame read around it, for its motion only.
    joined : str
        Where two streams were joined before this frame: ``'size'`` (the picture size
        changed; every frame is scaled to the first one's: :attr:`FrameSource.resized`),
        ``'time'`` (the timestamps started over; they are carried on:
        :attr:`FrameSource.restarts`), else ``''``.
    """

    planes: list[np.ndarray]
    start: float
    pts: int | None = None
    name: str | None = None
    keep: bool = True
    joined: str = ""


class _Onward:
    """Timestamps carried on where a stream starts over (two streams joined end to end).

    Where a timestamp is not past the last one, it and every later one are moved on to
    follow the last by its usual step, as ffmpeg's concatenation does: the output's
    timestamps keep increasing, and the motion's times too.
    """

    def __init__(self) -> None:
        self.offset = 0
        self._last: int | None = None
        self._step = 1

    def carry(self, pts: int | None) -> tuple[int | None, bool]:
        """Return ``pts`` carried on, and whether the stream started over there."""
        if pts is None:
            return None, False
        pts += self.offset
        restarted = self._last is not None and pts <= self._last
        if restarted:
            self.offset += self._last + self._step - pts  # type: ignore[operator]
            pts = self._last + self._step  # type: ignore[operator]
        elif self._last is not None:
            self._step = pts - self._last
        self._last = pts
        return pts, restarted

    def packet(self, packet: Any) -> None:
        """Carry an audio packet's timestamps on (in place)."""
        if packet.pts is None:
            return
        pts, _ = self.carry(packet.pts)
        shift = pts - packet.pts  # type: ignore[operator]
        if shift:
            packet.pts = pts
            if packet.dts is not None:
                packet.dts += shift


def _describe(img: np.ndarray) -> str:
    """``WxH, N channel(s)`` of an image, for messages."""
    channels = img.shape[2] if img.ndim == 3 else 1
    return f"{img.shape[1]}x{img.shape[0]}, {channels} channel{'s' if channels > 1 else ''}"


class FrameSource:
    """Read a video file or a folder of frames.

    Parameters
    ----------
    path : path-like
        A video PyAV can decode, or a folder of images (natural order of names).

    Raises
    ------
    InputError
        If it is missing, unreadable, empty, or its frames are smaller than 16 px.

    Examples
    --------
    ``with FrameSource(path) as src:`` then iterate ``src.items(fps)``: each
    :class:`Picture`, and (for a video) each audio packet, opaque, in file order.
    """

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = Path(path)
        self.pipe = is_pipe(path)  # standard input: one pass, nothing read twice
        if not self.pipe and not self.path.exists():
            raise InputError(f"{self.path}: no such file or folder")
        self.reader: VideoReader | None = None
        #: Whether :meth:`items` has passed the end of the part of the clip asked for.
        self.past_end = False
        #: Times the video's timestamps started over (streams joined), carried on since.
        self.restarts = 0
        if not self.pipe and self.path.is_dir():
            self._files = list_frames(self.path)
            self._first = read_image(self._files[0])
            h, w = self._first.shape[:2]
            max_value = (float(np.iinfo(self._first.dtype).max)
                         if np.issubdtype(self._first.dtype, np.integer) else 1.0)
            self.info = SourceInfo(self.path, False, w, h, None, len(self._files), max_value)
        else:
            self.reader = VideoReader(self.path)
            vi = self.reader.info
            self.info = SourceInfo(self.path, True, vi.width, vi.height, vi.fps, vi.frames,
                                   1023.0 if vi.bit_depth == 10 else 255.0, vi.time_base)
        if self.info.width < _MIN_SIZE or self.info.height < _MIN_SIZE:
            self.close()
            raise InputError(f"{self.path}: frames of {self.info.width}x{self.info.height} "
                             f"are too small (unjello needs at least {_MIN_SIZE}x{_MIN_SIZE})")

    def __enter__(self) -> FrameSource:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def resized(self) -> tuple[int, tuple[int, int] | None]:
        """Video frames read so far at another picture size (scaled), and the first such."""
        if self.reader is None:
            return 0, None
        return self.reader.resized, self.reader.other_size

    @property
    def damaged(self) -> int:
        """Video frames read so far that the decoder flagged as damaged (0 for a folder)."""
        return self.reader.damaged if self.reader is not None else 0

    def close(self) -> None:
        """Close the video file."""
        if self.reader is not None:
            self.reader.close()

    def items(self, fps: float | None = None, span: ClipSpan | None = None,
              before: int = 0) -> Iterator[Picture | object]:
        """Yield every :class:`Picture` in order, and a video's audio packets among them.

        Parameters
        ----------
        fps : float, optional
            The frame rate whose interval is the unit of the start times (default the
            video's own); a video frame starts at ``(pts - pts_0) * time_base * fps``,
            so a variable frame rate is kept. A folder's frame ``i`` starts at ``i``.
        span : ClipSpan, optional
            Only a part of the clip: its pictures come with ``keep`` set, their pts
            shifted so that the first is 0, and the audio packets within it, shifted
            alike. Around them come ``before`` pictures ahead of it and every picture
            after it (``keep`` False, for the motion's look-behind and look-ahead: the
            caller stops reading when it has what it needs; :attr:`past_end` says when
            the part is over). A video file is entered by seeking near the part's start.
        before : int
            Pictures read ahead of the span's start.

        Raises
        ------
        InputError
            A folder image that differs in size from the first, an undecodable frame,
            a video without frames, or a span that starts after the clip's end.
        """
        rate = float(fps or self.info.fps or 30.0)
        window = _Window(span, rate, before) if span is not None and not span.whole else None
        self.past_end = False
        if self.reader is None:
            for i, f in enumerate(self._files):
                keep: bool | None = True
                if window is not None:
                    keep = window.keep(i / rate)
                    if keep is None:
                        continue
                    self.past_end = window.over
                img = self._first if i == 0 else read_image(f)
                if img.shape != self._first.shape:
                    raise InputError(
                        f"{f.name}: {_describe(img)} differs from the first frame's "
                        f"{_describe(self._first)} (a folder must hold one clip's frames)")
                yield Picture([img], float(i), name=f.name, keep=bool(keep))
            if window is not None:
                window.check(self.path)
            return
        tb = float(self.info.time_base or 0)
        first: int | None = None
        if window is not None and not self.pipe and tb > 0 and window.seek_to > 1.0:
            first = self.reader.start_pts()
            self.reader.seek(first + int(window.seek_to / tb))
        n = 0
        video, sound = _Onward(), _Onward()
        for kind, item, pts in self.reader.packets():
            if kind == "audio":
                if window is None:
                    sound.packet(item)
                    yield item
                else:
                    yield from window.audio(item)
                continue
            pts, restarted = video.carry(pts)
            self.restarts += restarted
            if first is None and pts is not None:
                first = pts
            if window is not None and first is not None:
                window.zero = first * tb
            known = pts is not None and first is not None
            start = (pts - first) * tb * rate if known else float(n)  # type: ignore[operator]
            n += 1
            joined = "size" if self.reader.size_changed else "time" if restarted else ""
            if window is None:
                yield Picture(item, start, pts=pts, joined=joined)  # type: ignore[arg-type]
                continue
            inside = window.keep(start / rate)
            if inside is None:
                continue
            self.past_end = window.over
            shifted = (pts - first - round(window.offset / tb)  # type: ignore[operator]
                       if inside and known else pts)
            yield Picture(item, start, pts=shifted, keep=inside,  # type: ignore[arg-type]
                          joined=joined)
            if inside:
                yield from window.audio(None)  # what waited for the first picture's time
        if window is not None and (n or first is not None):
            window.check(self.path)
        if n == 0:
            raise InputError(f"{self.path}: the video has no frames")

    def pictures(self, fps: float | None = None, limit: int | None = None
                 ) -> Iterator[Picture]:
        """Yield the pictures only (audio skipped), at most ``limit`` of them."""
        n = 0
        for item in self.items(fps):
            if isinstance(item, Picture):
                if limit is not None and n >= limit:
                    return
                yield item
                n += 1


def read_frames(path: str | os.PathLike) -> Iterator[np.ndarray]:
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


class _Window:
    """Which pictures and audio packets of a :class:`ClipSpan` are kept, and their shift.

    Times are seconds from the clip's first frame. The kept part starts at the first
    picture at or after ``span.start`` (its time is the output's zero) and lasts
    ``span.duration`` (seconds, or a count of pictures).
    """

    def __init__(self, span: ClipSpan, rate: float, before: int) -> None:
        self.rate = rate
        self.start = span.start.seconds(rate) if span.start is not None else 0.0
        self.count = (round(span.duration.value) if span.duration is not None
                      and span.duration.unit == "f" else None)
        self.length = (span.duration.seconds(rate) if span.duration is not None
                       else float("inf"))
        self.first = self.start - before / rate  # the look-behind's first picture
        self.seek_to = max(0.0, self.first - 1.0 / rate)
        self.offset: float | None = None  # the first kept picture's time
        self.zero = 0.0  # the clip's first picture's time in the file (its audio's clock)
        self.end = self.start + self.length  # until the first picture is known
        self.kept = 0
        self.over = False
        self._waiting: list[Any] = []  # audio packets before the first kept picture

    def keep(self, t: float) -> bool | None:
        """Return whether the picture at ``t`` is kept; None: not even read around it."""
        slack = 0.25 / self.rate  # times round to the time base
        if t < self.first - slack:
            return None
        inside = (not self.over and t >= self.start - slack
                  and (self.kept < self.count if self.count is not None
                       else t < self.end - slack))
        if inside:
            if self.offset is None:
                self.offset = t
                self.end = t + (self.count / self.rate if self.count is not None
                                else self.length)
            self.kept += 1
            if self.count is not None and self.kept == self.count:
                self.end = t + 1.0 / self.rate
        elif self.offset is not None:
            self.over = True
        return inside

    def audio(self, packet: Any) -> Iterator[Any]:
        """Yield the audio packets of the kept part, shifted; None: release those waiting."""
        if packet is not None and self.offset is None:
            self._waiting.append(packet)
            return
        for p in [*self._waiting, *([packet] if packet is not None else [])]:
            tb = float(p.time_base)
            t = float(p.pts) * tb - self.zero
            if self.offset is not None and self.offset - 1e-6 <= t < self.end:
                shift = round((self.zero + self.offset) / tb)
                p.pts -= shift
                if p.dts is not None:
                    p.dts -= shift
                yield p
        self._waiting = []

    def check(self, path: Path) -> None:
        """Refuse a part that starts after the clip's end."""
        if self.offset is None:
            raise InputError(f"{path}: start={self.start:g} s is past the clip's end")
