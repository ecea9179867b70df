"""Segments of one video: where its keyframes are, decoding from one, joining the parts.

A long clip is corrected in segments that start at keyframes (:mod:`unjello.run.segments`);
this module does their file work with PyAV: the presentation timestamps of every frame
and which frames are keyframes (from the packets alone, nothing decoded), the frames of
a stretch of the clip (seeking to the keyframe before it), and the join of the encoded
segments into one file without re-encoding them, the source's audio copied once.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import av
import numpy as np

from ..errors import InputError, OutputError
from .video import VideoReader

__all__ = ["FrameIndex", "frame_index", "read_stretch", "join_segments"]


@dataclass(frozen=True)
class FrameIndex:
    """Every frame of a video by presentation order.

    Attributes
    ----------
    pts : tuple of int
        Each frame's presentation timestamp, in order.
    keyframes : tuple of int
        Indices (into ``pts``) of the frames a decoder can start from.
    """

    pts: tuple[int, ...]
    keyframes: tuple[int, ...]


def frame_index(path: str | os.PathLike) -> FrameIndex:
    """Read the timestamps and keyframes of a video's frames from its packets.

    Raises
    ------
    InputError
        A video whose packets carry no timestamps (a raw stream): it cannot be seeked.
    """
    with VideoReader(path) as reader:
        try:
            pts, keys = reader.packet_times()
        except InputError:
            raise InputError(f"{path}: its frames carry no timestamps, so it cannot be split "
                             "into segments") from None
    order = sorted(pts)
    return FrameIndex(tuple(order), tuple(i for i, p in enumerate(order) if p in keys))


def read_stretch(path: str | os.PathLike, first: int, last: int
                 ) -> Iterator[tuple[list[np.ndarray], int]]:
    """Yield the planes and pts of the frames ``first <= pts <= last`` of a video.

    Decoding starts at the keyframe at or before ``first`` (a seek), and the frames
    before ``first`` are decoded and dropped.
    """
    with VideoReader(path) as reader:
        reader.seek(first)
        for _, planes, pts in reader.packets(audio=False):
            if pts is None or pts < first:
                continue
            if pts > last:
                return
            yield planes, pts  # type: ignore[misc]


def join_segments(parts: Sequence[Path], source: str | os.PathLike, dst: Path) -> int:
    """Join encoded segments into ``dst`` without re-encoding, with the source's audio.

    The parts hold consecutive frames with the source's timestamps (the same codec
    settings, each starting with a keyframe); their packets are copied in order into one
    video stream, and the source's audio packets are copied once, interleaved by time.

    Returns
    -------
    int
        The video packets written.
    """
    try:
        out = av.open(str(dst), "w")
    except (av.FFmpegError, ValueError) as exc:
        raise OutputError(f"{dst}: cannot create output ({exc})") from None
    src = av.open(str(source))
    opened = [av.open(str(p)) for p in parts]
    try:
        template = opened[0].streams.video[0]
        video = out.add_stream_from_template(template)
        audio = {a.index: out.add_stream_from_template(a) for a in src.streams.audio}
        written = 0
        queue = _by_time(_video_packets(opened), src.demux(*src.streams.audio)
                         if src.streams.audio else iter(()))
        for packet in queue:
            if packet.stream.type == "video":
                packet.stream = video
                written += 1
            else:
                if packet.dts is None:
                    continue
                packet.stream = audio[packet.stream.index]
            out.mux(packet)
        return written
    finally:
        for c in opened:
            c.close()
        src.close()
        out.close()


def _video_packets(containers: Sequence[av.container.InputContainer]) -> Iterator[av.Packet]:
    for c in containers:
        for packet in c.demux(c.streams.video[0]):
            if packet.size:
                yield packet


def _by_time(a: Iterator[av.Packet], b: Iterator[av.Packet]) -> Iterator[av.Packet]:
    """Merge two packet streams by decode time (each already in order)."""

    def when(p: av.Packet) -> float:
        t = p.dts if p.dts is not None else p.pts
        return float((t or 0) * p.time_base)

    pa, pb = next(a, None), next(b, None)
    while pa is not None or pb is not None:
        if pb is None or (pa is not None and when(pa) <= when(pb)):
            yield pa  # type: ignore[misc]
            pa = next(a, None)
        else:
            yield pb
            pb = next(b, None)
