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

import numpy as np

from ..errors import InputError
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
    """

    planes: list[np.ndarray]
    start: float
    pts: int | None = None
    name: str | None = None


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
    def damaged(self) -> int:
        """Video frames read so far that the decoder flagged as damaged (0 for a folder)."""
        return self.reader.damaged if self.reader is not None else 0

    def close(self) -> None:
        """Close the video file."""
        if self.reader is not None:
            self.reader.close()

    def items(self, fps: float | None = None) -> Iterator[Picture | object]:
        """Yield every :class:`Picture` in order, and a video's audio packets among them.

        Parameters
        ----------
        fps : float, optional
            The frame rate whose interval is the unit of the start times (default the
            video's own); a video frame starts at ``(pts - pts_0) * time_base * fps``,
            so a variable frame rate is kept. A folder's frame ``i`` starts at ``i``.

        Raises
        ------
        InputError
            A folder image that differs in size from the first, an undecodable frame,
            or a video without frames.
        """
        if self.reader is None:
            for i, f in enumerate(self._files):
                img = self._first if i == 0 else read_image(f)
                if img.shape != self._first.shape:
                    raise InputError(
                        f"{f.name}: {_describe(img)} differs from the first frame's "
                        f"{_describe(self._first)} (a folder must hold one clip's frames)")
                yield Picture([img], float(i), name=f.name)
            return
        rate = float(fps or self.info.fps or 30.0)
        tb = float(self.info.time_base or 0)
        first: int | None = None
        n = 0
        for kind, item, pts in self.reader.packets():
            if kind == "audio":
                yield item
                continue
            if first is None and pts is not None:
                first = pts
            start = (pts - first) * tb * rate if pts is not None and first is not None \
                else float(n)
            yield Picture(item, start, pts=pts)  # type: ignore[arg-type]
            n += 1
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
