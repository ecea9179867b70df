"""Writing outputs safely: temp file + rename, and nothing overwritten unless asked.

* :func:`check_paths` refuses what must never happen (the output is the input, lies
  inside it, exists without ``overwrite=True``, or its folder is missing).
* :class:`PictureSink` writes the corrected pictures of a :class:`~unjello.io.source.FrameSource`
  like their source: a video with the same size, rate, pts, rotation, colour tags and
  audio packets; a folder with the same file names.
* :class:`FrameSink` writes RGB frames to a new video or a folder of PNGs.

Every output is written under a hidden temporary name beside its destination and moved
into place only when complete; on an error or Ctrl-C the partial output is removed.
"""

from __future__ import annotations

import os
import queue
import shutil
import threading
import uuid
from pathlib import Path

import numpy as np

from ..errors import OutputError, cannot_write
from .frames import rgb8, write_image
from .source import FrameSource, Picture
from .video import VIDEO_SUFFIXES, EncodeOptions, VideoWriter, is_pipe

__all__ = ["temp_path", "replace", "remove", "check_new", "check_paths", "PictureSink",
           "FrameSink", "make_folder", "ThreadedWriter"]


def make_folder(path: Path) -> None:
    """Create an output folder (a temporary one), or say in one line why it cannot be."""
    try:
        path.mkdir()
    except OSError as exc:
        raise cannot_write(path, exc) from None


def temp_path(dst: Path) -> Path:
    """Return a hidden temporary name beside ``dst`` (same folder: the rename is atomic)."""
    return dst.with_name(f".{dst.stem}.unjello-{uuid.uuid4().hex[:8]}{dst.suffix}")


def remove(path: Path) -> None:
    """Remove a file or a folder, if it exists."""
    if path.is_dir():
        shutil.rmtree(path, ignore_errors=True)
    elif path.exists():
        path.unlink()


def replace(tmp: Path, dst: Path) -> None:
    """Move a finished ``tmp`` into place, replacing ``dst`` (a file or a folder)."""
    if dst.is_dir():
        shutil.rmtree(dst)
    elif dst.exists():
        dst.unlink()
    os.replace(tmp, dst)


def check_new(dst: str | os.PathLike | None, overwrite: bool) -> None:
    """Refuse an output that exists (without ``overwrite``) or whose folder is missing."""
    if dst is None:
        return
    dst = Path(dst)
    if dst.exists() and not overwrite:
        raise OutputError(f"{dst} exists; pass overwrite=True to replace it")
    parent = dst.parent if str(dst.parent) else Path(".")
    if not parent.exists():
        raise OutputError(f"{parent}: output folder does not exist")
    if not os.access(parent, os.W_OK):
        raise OutputError(f"{parent}: output folder is not writable")


def check_paths(src: Path, dst: Path, overwrite: bool) -> None:
    """Refuse an output that would clobber the input or an existing file.

    Raises
    ------
    OutputError
        The output is the input or lies inside the input folder, is a folder where a
        video goes, exists without ``overwrite``, or its folder is missing.
    """
    if is_pipe(dst) or is_pipe(src):  # standard input or output: nothing to clobber
        if is_pipe(src) and not is_pipe(dst):
            check_new(dst, overwrite)
        return
    if dst.resolve() == src.resolve() or (dst.exists() and os.path.samefile(src, dst)):
        raise OutputError(f"output {dst} is the input; choose another name")
    if src.is_file() and dst.is_dir():
        raise OutputError(f"{dst} is a folder; give the output video a file name")
    if src.is_dir() and dst.resolve().is_relative_to(src.resolve()):
        raise OutputError(f"output {dst} is inside the input folder; choose another place")
    check_new(dst, overwrite)


class PictureSink:
    """Write corrected pictures like their source, atomically.

    Parameters
    ----------
    dst : Path
        The output video, or folder (for a folder source).
    source : FrameSource
        The source whose format, timing, metadata and names are kept.
    encode : EncodeOptions
        Encoder settings of a video.
    fps : float
        Frame rate of a video made from a folder of frames (a ``dst`` with a video
        suffix).
    """

    def __init__(self, dst: Path, source: FrameSource,
                 encode: EncodeOptions = EncodeOptions(), fps: float = 30.0) -> None:
        self.dst = dst
        self._pipe = is_pipe(dst)  # standard output: written as it goes, nothing to rename
        self._tmp = dst if self._pipe else temp_path(dst)
        self._video: ThreadedWriter | None = None
        self._frames: FrameSink | None = None  # a folder of frames made into a video
        if source.reader is not None:
            self._video = ThreadedWriter(VideoWriter.like(self._tmp, source.reader, encode))
        elif self._pipe or dst.suffix.lower() in VIDEO_SUFFIXES:
            if source.info.width % 2 or source.info.height % 2:
                raise OutputError(f"frames of {source.info.width}x{source.info.height} make "
                                  "no video (it needs an even width and height): give -o a "
                                  "folder")
            self._frames = FrameSink(dst, fps, True, encode)
        else:
            make_folder(self._tmp)
        self.frames_written = 0

    def write(self, picture: Picture, planes: list[np.ndarray]) -> None:
        """Write the corrected ``planes`` of ``picture`` (its pts or its name kept)."""
        if self._video is not None:
            self._video.write(planes, picture.pts)
            self.frames_written = self._video.frames_written
        elif self._frames is not None:
            self._frames.write(rgb8(planes[0]))
            self.frames_written += 1
        else:
            write_image(self._tmp / str(picture.name), planes[0])
            self.frames_written += 1

    def copy_audio(self, packet: object) -> None:
        """Copy one audio packet of the source unchanged."""
        if self._video is not None:
            self._video.copy_audio(packet)

    def close(self) -> None:
        """Finish and move the output into place."""
        if self._frames is not None:
            self._frames.close()
            return
        if self._video is not None:
            self._video.close()
        if not self._pipe:
            replace(self._tmp, self.dst)

    def abort(self) -> None:
        """Drop the partial output."""
        if self._frames is not None:
            self._frames.abort()
            return
        if self._video is not None:
            self._video.abort()
        if not self._pipe:
            remove(self._tmp)


class FrameSink:
    """Write RGB frames to a video file or a folder of PNGs, atomically.

    Parameters
    ----------
    path : path-like
        ``*.mp4`` (or another video suffix) or ``-`` (standard output) for a video,
        anything else for a folder that receives ``frame_00000.png`` ...
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
        self._pipe = is_pipe(path)  # standard output: a video, written as it goes
        if not self._pipe:
            check_new(self.path, overwrite)
        self.is_video = self._pipe or self.path.suffix.lower() in VIDEO_SUFFIXES
        self._tmp = self.path if self._pipe else temp_path(self.path)
        self._fps, self._encode = fps, encode
        self._writer: VideoWriter | None = None
        self._n = 0
        if not self.is_video:
            make_folder(self._tmp)

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
        if not self._pipe:
            replace(self._tmp, self.path)

    def abort(self) -> None:
        """Drop the partial output."""
        if self._writer is not None:
            self._writer.abort()
        if not self._pipe:
            remove(self._tmp)

    def __enter__(self) -> FrameSink:
        return self

    def __exit__(self, exc_type: object, *rest: object) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()


class ThreadedWriter:
    """Run a :class:`VideoWriter` in a background thread, so encoding overlaps the work.

    Video frames and audio packets go through one bounded queue, in order, so the
    container is only touched by the writer thread. An encoder error is raised again by
    the next call, or by :meth:`close`.

    Parameters
    ----------
    writer : VideoWriter
        The writer to drive.
    depth : int
        Frames queued at most (bounds memory).
    """

    def __init__(self, writer: VideoWriter, depth: int = 4) -> None:
        self._w = writer
        self._queued = 0
        self._q: queue.Queue = queue.Queue(maxsize=depth)
        self._error: BaseException | None = None
        self._aborted = False
        self._thread = threading.Thread(target=self._run, name="unjello-encoder", daemon=True)
        self._thread.start()

    @property
    def frames_written(self) -> int:
        """Frames handed to the writer so far."""
        return self._queued

    def _run(self) -> None:
        while True:
            item = self._q.get()
            if item is None:
                return
            if self._error is not None or self._aborted:
                continue
            try:
                if item[0] == "v":
                    self._w.write(item[1], item[2])
                else:
                    self._w.copy_audio(item[1])
            except BaseException as exc:  # noqa: BLE001 - re-raised in the caller's thread
                self._error = exc

    def _check(self) -> None:
        if self._error is not None:
            raise self._error

    def write(self, planes: list[np.ndarray], pts: int | None) -> None:
        """Queue a frame (see :meth:`VideoWriter.write`)."""
        self._check()
        self._queued += 1
        self._q.put(("v", planes, pts))

    def copy_audio(self, packet: object) -> None:
        """Queue an audio packet (see :meth:`VideoWriter.copy_audio`)."""
        self._check()
        self._q.put(("a", packet))

    def close(self) -> None:
        """Drain the queue, flush the encoder and close the file."""
        self._q.put(None)
        self._thread.join()
        self._check()
        self._w.close()

    def abort(self) -> None:
        """Stop the thread and close without flushing, without waiting on a stuck output.

        What is queued is dropped (the output is being thrown away), so the stop signal
        never waits for room; a thread still stuck after a few seconds (writing into a pipe
        whose reader stopped reading) is left to end with the process, its file unclosed
        rather than closed under it.
        """
        self._aborted = True
        self._w.cut()
        while True:
            try:
                self._q.get_nowait()
            except queue.Empty:
                break
        self._q.put_nowait(None)
        self._thread.join(timeout=5)
        if not self._thread.is_alive():
            self._w.abort()
