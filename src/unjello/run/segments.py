"""One long clip on a cluster: segments corrected on workers, joined without re-encoding.

The clip is cut at keyframes into segments; each is corrected on a worker (a local
process pool, Dask or Ray, through :func:`unjello.run.batch.executor`) from the frames it
writes plus the context its method needs on both sides (its solve window: five frames
for the dense method, 33 with vibration; the smoothing window with ``stabilize``), which
it decodes and drops. What is decided for the clip as a whole is decided once, on the
driver, before any segment starts: the readout (its estimate too), the scan direction,
the frame rate and ``vibration='auto'``'s choice. The encoded segments are joined into
one file by copying their packets (no second encode), the source's audio copied once.

A run is resumable: finished segments are kept in a folder beside the output
(``.NAME.segments``) with the settings they were made with, and a run with the same
settings redoes only the missing ones; a failed segment stops the run with one message
and nothing is written to the output.
"""

from __future__ import annotations

import concurrent.futures as cf
import dataclasses
import hashlib
import json
import os
import pickle
import shutil
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..clip import ResolvedTiming, resolve_clip
from ..config import CorrectionConfig
from ..corrector import Corrector, _luma255
from ..errors import InputError, SettingsError, UnjelloError
from ..io.codecs import check_output
from ..io.remux import FrameIndex, frame_index, join_segments, read_stretch
from ..io.sink import check_paths, remove, replace, temp_path
from ..io.source import FrameSource
from ..io.video import VideoReader, VideoWriter
from ..motion.dense.method import DenseMethod
from ..pipeline import _light
from ..stabilize import Stabilizer
from ..timing import SensorTiming, to_top_bottom
from ..trajectory import FrameMotion, Trajectory
from .batch import executor
from .heap import trim
from .parallel import cores, frame_threads

__all__ = ["Segment", "plan_segments", "context_frames", "correct_segmented",
           "FRAMES_PER_SEGMENT"]

#: ``segments='auto'``: at least one segment per worker, and none much longer than this.
FRAMES_PER_SEGMENT = 300


class SegmentError(UnjelloError, RuntimeError):
    """A segment failed on its worker (the message says which and why)."""


@dataclass(frozen=True)
class Segment:
    """Frames ``start <= i < end`` of a clip, corrected from ``lead <= i < tail``."""

    index: int
    start: int
    end: int
    lead: int
    tail: int


def plan_segments(frames: int, keyframes: tuple[int, ...], count: int, context: int
                  ) -> list[Segment]:
    """Cut ``frames`` frames at keyframes into at most ``count`` segments of similar length.

    Each segment starts at the keyframe nearest to its share of the clip, and is given
    ``context`` frames on both sides (within the clip).

    Examples
    --------
    >>> [(s.start, s.end, s.lead, s.tail) for s in plan_segments(90, (0, 30, 60), 3, 5)]
    [(0, 30, 0, 35), (30, 60, 25, 65), (60, 90, 55, 90)]
    """
    keys = sorted(set(keyframes) | {0})
    starts = sorted({min(keys, key=lambda k: abs(k - frames * i / count)) for i in range(count)})
    starts = [s for s in starts if s < frames]
    ends = [*starts[1:], frames]
    return [Segment(i, s, e, max(0, s - context), min(frames, e + context))
            for i, (s, e) in enumerate(zip(starts, ends, strict=True))]


def context_frames(config: CorrectionConfig, fps: float) -> int:
    """Return the frames of context a segment needs on each side (as in one run).

    The method's solve window and a frame, and the stabiliser's look-ahead and smoothing
    window.
    """
    if config.method == "paper":
        ctx = 4
    else:
        d = config.dense
        ctx = d.history + d.window + 1
    if config.stabilize.enabled:
        stab = Stabilizer(config.stabilize, SensorTiming(), (64, 64), fps)
        ctx += stab.radius + stab.lookahead
    return ctx


def _decide_vibration(source: FrameSource, timing: SensorTiming, config: CorrectionConfig,
                      fps: float) -> tuple[CorrectionConfig, float | None]:
    """Decide ``vibration='auto'`` once, from the clip's first frames, as one run would.

    Returns the settings with ``on`` or ``off``, and the wobble detected (or None).
    """
    if config.method != "dense" or config.dense.vibration != "auto":
        return config, None
    method = DenseMethod(timing, config.dense)
    for picture in source.pictures(fps):  # the grey frames a Corrector gives its method
        method.push(_luma255(to_top_bottom(picture.planes[0], timing.direction),
                             source.info.max_value), picture.start)
        if method.vibrating is not None:
            break
    if method.vibrating is None:
        method.flush()
    on = "on" if method.vibrating else "off"
    return (dataclasses.replace(config, dense=dataclasses.replace(config.dense, vibration=on)),
            method.wobble)


@dataclass(frozen=True)
class _Job:
    source: str
    part: str
    segment: Segment
    config: CorrectionConfig
    timing: SensorTiming
    fps: float
    pts: tuple[int, ...]  # every frame's pts
    threads: int


def run_segment(job: _Job) -> list[FrameMotion]:
    """Correct one segment on a worker into its part file (temp + rename).

    Returns
    -------
    list of FrameMotion
        The motion of the frames it wrote (per scanline; fields dropped).
    """
    seg = job.segment
    part = Path(job.part)
    tmp = temp_path(part)
    with VideoReader(job.source) as reader:
        info = reader.info
        writer = VideoWriter(tmp, size=(info.width, info.height), fps=info.fps,
                             time_base=info.time_base, pix_fmt=reader.work_format,
                             options=job.config.encode, rotation=info.rotation,
                             color=info.color)
    tb = float(info.time_base or 0)
    first = job.pts[0]
    wanted = {p: i for i, p in enumerate(job.pts[seg.start:seg.end], start=seg.start)}
    motions: list[FrameMotion] = []
    try:
        threads = job.threads or cores()
        with frame_threads(threads) as pool:
            corr = Corrector(job.timing, job.config,
                             max_value=1023.0 if info.bit_depth == 10 else 255.0,
                             fps=job.fps, executor=pool, workers=threads,
                             only=set(range(seg.start - seg.lead, seg.end - seg.lead)))
            frames = read_stretch(job.source, job.pts[seg.lead], job.pts[seg.tail - 1])
            held: deque[int] = deque()

            def emit(done: list) -> None:
                for planes, fm in done:
                    pts = held.popleft()
                    if pts in wanted:
                        writer.write(planes, pts)
                        motions.append(dataclasses.replace(_light(fm), index=wanted[pts]))
                        trim(len(motions))  # the freed memory back, as a whole run does

            for planes, pts in frames:
                held.append(pts)
                emit(corr.push(planes, (pts - first) * tb * job.fps))
            emit(corr.flush())
        if len(motions) != seg.end - seg.start:
            raise InputError(f"decoded {len(motions)} of its {seg.end - seg.start} frames")
        writer.close()
    except BaseException:
        writer.abort()
        remove(tmp)
        raise
    os.replace(tmp, part)
    return motions


def _key(src: Path, config: CorrectionConfig, timing: SensorTiming, plan: list[Segment]
         ) -> str:
    st = src.stat()
    text = repr((str(src.resolve()), st.st_size, st.st_mtime_ns, config, timing,
                 [dataclasses.astuple(s) for s in plan]))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def correct_segmented(
    src: str | os.PathLike,
    dst: str | os.PathLike,
    config: CorrectionConfig = CorrectionConfig(),
    *,
    segments: int | str = "auto",
    kind: str = "local",
    address: str | None = None,
    workers: int | None = None,
    overwrite: bool = False,
    log: Callable[[str], None] | None = None,
    on_timing: Callable[[ResolvedTiming], None] | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> tuple[Trajectory, dict[str, Any]]:
    """Correct a video in segments on an executor's workers, joined into ``dst``.

    Parameters
    ----------
    src, dst : path-like
        A video file, and the output video.
    config : CorrectionConfig
        The settings (the dense or paper method; not a gyro).
    segments : int or 'auto'
        How many segments (at keyframes; fewer if the clip has fewer keyframes). ``auto``:
        one per worker, more for a long clip (:data:`FRAMES_PER_SEGMENT`).
    kind, address, workers
        The executor (:func:`unjello.run.batch.executor`): ``local``, ``dask`` or ``ray``, a
        cluster's address, worker processes of a local one.
    overwrite : bool
        Replace an existing output.
    log, on_timing, progress
        As :func:`unjello.pipeline.correct_video`; ``progress(done, total)`` counts
        segments.

    Returns
    -------
    trajectory : Trajectory
        The motion per scanline of every frame.
    report : dict
        ``segments`` (a list of ``{index, start, end, status}``, status ``done`` or
        ``kept`` from an earlier run), ``seconds``.

    Raises
    ------
    SegmentError
        A segment that failed (its number, frames and error); the finished ones are kept
        for the next run.
    """
    t0 = time.perf_counter()
    src_p, dst_p = Path(src), Path(dst)
    if not src_p.is_file():
        raise InputError(f"{src_p}: segments need a video file" if src_p.exists()
                         else f"{src_p}: no such file or folder")
    check_paths(src_p, dst_p, overwrite)
    check_output(config.encode.codec, config.encode.profile, dst_p)
    if not config.span.whole:
        raise SettingsError("a part of a clip (start=, duration=) is corrected in one run: "
                            "leave out segments")
    if config.method == "gyro":
        raise SettingsError("segments take the dense or the paper method; a gyro's "
                            "calibration is made over the whole clip: correct it in one run")
    with FrameSource(src_p) as source:
        config, resolved, *_ = resolve_clip(config, src_p, source)
        for message in resolved.messages:
            if log:
                log(message)
        if on_timing:
            on_timing(resolved)
        config, wobble = _decide_vibration(source, resolved.timing, config, resolved.fps)
        size = (source.info.width, source.info.height)
    index: FrameIndex = frame_index(src_p)
    n = len(index.pts)
    if n == 0:
        raise InputError(f"{src_p}: the video has no frames")
    per_worker = workers or os.cpu_count() or 1
    if segments == "auto":
        count = max(per_worker, -(-n // FRAMES_PER_SEGMENT))
    else:
        count = int(segments)
        if count < 1:
            raise SettingsError(f"segments must be 1 or more, or auto, not {segments!r}")
    plan = plan_segments(n, index.keyframes, count, context_frames(config, resolved.fps))
    if log and len(plan) < count:
        log(f"{len(plan)} segment(s): the clip has {len(index.keyframes)} keyframe(s) to "
            "cut at")
    work = dst_p.with_name(f".{dst_p.name}.segments")
    key = _key(src_p, config, resolved.timing, plan)
    manifest = work / "settings.json"
    if work.exists() and (not manifest.exists()
                          or json.loads(manifest.read_text()).get("key") != key):
        shutil.rmtree(work)  # made with other settings: not reused
    work.mkdir(exist_ok=True)
    manifest.write_text(json.dumps({"key": key, "source": str(src_p), "segments": len(plan)}))
    parts = [work / f"part_{s.index:04d}.mp4" for s in plan]
    motions_file = [work / f"part_{s.index:04d}.motion.pickle" for s in plan]
    status = {s.index: "kept" for s, p, m in zip(plan, parts, motions_file, strict=True)
              if p.exists() and m.exists()}
    threads = 1 if kind != "local" or per_worker > 1 else 0
    jobs = {s.index: _Job(str(src_p), str(parts[s.index]), s, config, resolved.timing,
                          resolved.fps, index.pts, threads)
            for s in plan if s.index not in status}
    motions: dict[int, list[FrameMotion]] = {i: _load_motions(motions_file[i])
                                             for i in status}
    failures = []
    with executor(kind, address, per_worker) as ex:
        futures = {ex.submit(run_segment, job): i for i, job in jobs.items()}
        for fut in cf.as_completed(futures):
            i = futures[fut]
            seg = plan[i]
            try:
                motions[i] = fut.result()
            except Exception as exc:  # noqa: BLE001 - said in one line, the rest kept
                failures.append(f"segment {i + 1} of {len(plan)} (frames {seg.start}-"
                                f"{seg.end - 1}) failed: {exc}")
                continue
            _save_motions(motions_file[i], motions[i])
            status[i] = "done"
            if progress:
                progress(len(status), len(plan))
    if failures:
        raise SegmentError("; ".join(failures) + f" (the finished segments are kept in "
                           f"{work}: run the command again to redo only the others)")
    tmp = temp_path(dst_p)
    try:
        join_segments(parts, src_p, tmp)
    except BaseException:
        remove(tmp)
        raise
    replace(tmp, dst_p)
    shutil.rmtree(work, ignore_errors=True)
    traj = Trajectory(resolved.timing, size, method=config.method, vibration=wobble)
    traj.frames = [fm for i in sorted(motions) for fm in motions[i]]
    report = {"segments": [{"index": s.index, "start": s.start, "end": s.end,
                            "status": status[s.index]} for s in plan],
              "seconds": round(time.perf_counter() - t0, 3)}
    kept = sum(v == "kept" for v in status.values())
    if log:
        log(f"{len(plan)} segment(s) on {kind}" + (f", {kept} kept from an earlier run"
                                                   if kept else ""))
    return traj, report


def _save_motions(path: Path, motions: list[FrameMotion]) -> None:
    """Keep a finished segment's motion beside its part (for a resumed run's summary)."""
    tmp = path.with_name(path.name + ".tmp")
    with tmp.open("wb") as f:
        pickle.dump(motions, f)
    os.replace(tmp, path)


def _load_motions(path: Path) -> list[FrameMotion]:
    with path.open("rb") as f:
        return pickle.load(f)  # noqa: S301 - written by this module into the run's folder
