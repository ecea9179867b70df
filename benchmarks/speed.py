"""Speed and memory of `unjello correct` against a plain transcode, measured in one run.

1. Builds a 1080p30 rolling-shutter clip (hand-shake motion over a photo, 300 frames
   by default) with the simulator, plus an AAC audio track.
2. T0: a plain PyAV transcode of it (decode -> encode with unjello's default codec,
   CRF and preset, audio copied). T1: `unjello correct` (default method) on the same
   clip, and with ``--preset fast``; and `--method paper` on its first frames (reported
   per frame).
3. The correction stage alone (decoded YUV planes in memory, motion + warp), default
   and ``--preset fast``: frames per second, and the top lines of a cProfile of it.
4. Peak resident memory of `unjello correct` (a child process) on 100 and 1000 frames
   at 640x360; on a 4K (3840x2160) clip of 60 frames, beside the plain transcode's (also
   a child process) and the ratio of their wall times.

With ``--profile`` it measures instead where the CPU time goes, stage by stage, at 1080p
and 4K: the clip decoded, corrected and encoded one stage after another in this process,
single-threaded (OpenCV's threads off, no pool), each stage's CPU time (user + sys) per
frame, exclusive of the stages it calls, in the correction's second pass over the clip
(the first faults in its memory; its total is printed too); and the wall ratio of
`unjello correct` to a plain transcode of the same clip, measured in the same run.

Usage::

    python benchmarks/speed.py [--frames 300] [--rounds 3] [--skip-memory]
    python benchmarks/speed.py --profile [--frames 60] [--k4-frames 20]
"""

from __future__ import annotations

import argparse
import cProfile
import importlib
import io
import os
import pstats
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import av
import numpy as np
from skimage import data

from unjello._kernels import pixelwise as kernels
from unjello.config import CorrectionConfig
from unjello.io.video import EncodeOptions, VideoReader, VideoWriter
from unjello.motion.dense.method import DenseConfig
from unjello.pipeline import Corrector
from unjello.simulate import Motion, simulate
from unjello.timing import SensorTiming


def build_clip(path: Path, frames: int, size: tuple[int, int], fps: int = 30,
               keyint: int = 60) -> None:
    """Write a simulated rolling-shutter clip with a sine audio track.

    A keyframe every ``keyint`` frames (two seconds: as cameras write; segments start
    at keyframes).
    """
    with av.open(str(path), "w") as out:
        vs = out.add_stream("libx264", rate=fps)
        vs.width, vs.height = size
        vs.pix_fmt = "yuv420p"
        vs.options = {"crf": "18", "preset": "veryfast", "g": str(keyint)}
        ast = out.add_stream("aac", rate=48000)
        sim = simulate(data.astronaut(), Motion("shake", fps=fps, amplitude=2.0),
                       SensorTiming(0.9), frames, size=size)
        for i, s in enumerate(sim):
            for p in vs.encode(av.VideoFrame.from_ndarray(s.rolling, format="rgb24")):
                out.mux(p)
            n = 48000 // fps
            t = (np.arange(n) + i * n) / 48000
            af = av.AudioFrame.from_ndarray((0.1 * np.sin(2 * np.pi * 440 * t))[None]
                                            .astype(np.float32), format="fltp", layout="mono")
            af.sample_rate, af.pts = 48000, i * n
            for p in ast.encode(af):
                out.mux(p)
        for p in vs.encode():
            out.mux(p)
        for p in ast.encode():
            out.mux(p)


def transcode(src: Path, dst: Path) -> None:
    """Plain decode -> encode with unjello's default encoder settings, audio copied."""
    with VideoReader(src) as reader:
        writer = VideoWriter.like(dst, reader, EncodeOptions())
        for kind, item, pts in reader.packets():
            if kind == "audio":
                writer.copy_audio(item)  # type: ignore[arg-type]
            else:
                writer.write(item, pts)  # type: ignore[arg-type]
        writer.close()


#: :func:`transcode` as a child process of its own, importing only what it uses (its peak
#: memory is compared with `unjello correct`'s).
TRANSCODE = """import sys
from unjello.io.video import EncodeOptions, VideoReader, VideoWriter
with VideoReader(sys.argv[1]) as reader:
    writer = VideoWriter.like(sys.argv[2], reader, EncodeOptions())
    for kind, item, pts in reader.packets():
        if kind == "audio":
            writer.copy_audio(item)
        else:
            writer.write(item, pts)
    writer.close()
"""


def cut(src: Path, dst: Path, frames: int) -> None:
    with VideoReader(src) as reader:
        writer = VideoWriter.like(dst, reader, EncodeOptions(preset="veryfast"))
        n = 0
        for kind, item, pts in reader.packets():
            if kind == "video":
                writer.write(item, pts)  # type: ignore[arg-type]
                n += 1
                if n >= frames:
                    break
        writer.close()


def timed(cmd: list[str]) -> tuple[float, float]:
    """Run a command; return (seconds, peak RSS of the child in MB)."""
    seconds, rss, _ = timed_cpu(cmd)
    return seconds, rss


def timed_cpu(cmd: list[str]) -> tuple[float, float, float]:
    """Run a command; return wall seconds, peak RSS (MB), CPU seconds (all its threads)."""
    t0 = time.perf_counter()
    res = subprocess.run(["/usr/bin/env", "python3", "-c",
                          "import resource,subprocess,sys;"
                          "r=subprocess.run(sys.argv[1:]);"
                          "u=resource.getrusage(resource.RUSAGE_CHILDREN);"
                          "print(u.ru_maxrss, u.ru_utime + u.ru_stime);"
                          "sys.exit(r.returncode)", *cmd], capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    if res.returncode != 0:
        raise SystemExit(f"failed: {' '.join(cmd)}\n{res.stderr}")
    rss, cpu = res.stdout.strip().splitlines()[-1].split()
    return seconds, int(rss) / 1024.0, float(cpu)


def _self_cpu() -> float:
    """CPU seconds (user + sys, every thread) this process has used so far."""
    import resource

    u = resource.getrusage(resource.RUSAGE_SELF)
    return u.ru_utime + u.ru_stime


FAST = CorrectionConfig(dense=DenseConfig(per_pixel=False, flow_preset="ultrafast",
                                          work_width=320))


def stage_run(pictures: list, timing: SensorTiming, config: CorrectionConfig) -> float:
    """Correct pictures held in memory (motion + warp of every plane); return seconds."""
    t = time.perf_counter()
    corr = Corrector(timing, config)
    for i, planes in enumerate(pictures):
        corr.push(planes, float(i))
    corr.flush()
    return time.perf_counter() - t


#: What the profile measures: a label and the functions (module, attribute) it covers.
STAGES = (
    ("luma (to top-bottom, grey)", [("unjello.corrector", "_luma255"),
                                    ("unjello.corrector", "to_top_bottom")]),
    ("where the clip breaks", [("unjello.motion.cuts.Breaks", "add"),
                               ("unjello.motion.cuts.Breaks", "before")]),
    ("flow: DIS (and its large-motion rerun)", [("unjello.motion.flow.dis", "optical_flow")]),
    ("flow: inverse", [("unjello.motion.flow.dis", "invert_flow")]),
    ("flow: consistency", [("unjello.motion.flow.dis", "consistent")]),
    ("row summaries", [("unjello.motion.dense.method", "row_flows"),
                       ("unjello.motion.dense.vibration", "probe_pair")]),
    ("trajectory solve", [("unjello.motion.dense.method", "solve_camera_trajectory")]),
    ("per-pixel: snap to global", [("unjello.motion.dense.method", "snap_to_global")]),
    ("per-pixel: residual", [("unjello.motion.dense.method.DenseMethod", "_residual")]),
    ("per-pixel: fold / failed-flow checks", [("unjello.motion.dense.safety", "fold_share"),
                                              ("unjello.motion.dense.safety", "failed_blobs"),
                                              ("unjello.motion.dense.safety", "keep_whole"),
                                              ("unjello.motion.dense.safety.SafeField",
                                               "_missed"),
                                              ("unjello.motion.dense.safety.SafeField",
                                               "_changing"),
                                              ("unjello.motion.dense.safety.SafeField",
                                               "_turn_back_spinning")]),
    ("motion: the rest (working copy, field)", [("unjello.motion.dense.method.DenseMethod", "push"),
                                                ("unjello.motion.dense.method.DenseMethod",
                                                 "flush")]),
    ("backward map (fixed point, working grid)", [("unjello.warp.maps", "field_maps")]),
    ("map upsampling (per plane size)", [("unjello.warp.maps", "resize_maps"),
                                         ("unjello.warp.bands.PlaneMaps", "__init__"),
                                         ("unjello.warp.bands.PlaneMaps", "band")]),
    ("remap (every plane)", [("unjello.warp.warper", "apply_maps"),
                             ("unjello.warp.warper", "warp_bands")]),
    ("fill from neighbours", [("unjello.warp.fill.planes", "neighbour_sources"),
                              ("unjello.warp.fill.planes", "fill_from_neighbours"),
                              ("unjello.warp.fill.planes", "uncovered"),
                              ("unjello.warp.fill.planes", "confirmed"),
                              ("unjello.warp.fill.planes", "uncovered_sources"),
                              ("unjello.warp.fill.planes", "edge_objects"),
                              ("unjello.warp.fill.planes", "settled_objects"),
                              ("unjello.warp.fill.planes", "objects_beyond")]),
    ("per-scanline maps", [("unjello.warp.warper", "remap_maps"),
                           ("unjello.warp.maps", "remap_maps")]),
    ("warp: the rest", [("unjello.warp.warper.PictureWarper", "__call__")]),
)


class StageClock:
    """CPU time (user + sys of the process) per stage, exclusive of nested stages."""

    def __init__(self) -> None:
        self.totals: dict[str, float] = {}
        self._stack: list[list] = []  # [label, start, time spent in nested stages]
        self._undo: list[tuple[object, str, object]] = []

    def __enter__(self) -> StageClock:
        for label, targets in STAGES:
            for where, name in targets:
                owner = _resolve(where)
                self._undo.append((owner, name, owner.__dict__[name]))
                setattr(owner, name, self._wrap(label, owner.__dict__[name]))
        return self

    def __exit__(self, *exc: object) -> None:
        for owner, name, original in reversed(self._undo):
            setattr(owner, name, original)

    def _wrap(self, label: str, fn):  # noqa: ANN001, ANN202
        def timed(*a, **k):  # noqa: ANN002, ANN003, ANN202
            self._stack.append([label, _cpu(), 0.0])
            try:
                return fn(*a, **k)
            finally:
                lab, start, nested = self._stack.pop()
                spent = _cpu() - start
                self.totals[lab] = self.totals.get(lab, 0.0) + spent - nested
                if self._stack:
                    self._stack[-1][2] += spent
        return timed


def _resolve(where: str) -> object:
    """Return a module, or a class given as module.Class."""
    try:
        return importlib.import_module(where)
    except ImportError:
        mod, cls = where.rsplit(".", 1)
        return getattr(importlib.import_module(mod), cls)


def _cpu() -> float:
    return time.process_time()  # user + sys of every thread, at the clock's resolution


def profile_stages(clip: Path, out: Path, frames: int,
                   config: CorrectionConfig = CorrectionConfig()) -> dict[str, float]:
    """Decode, correct and encode ``clip`` stage after stage; CPU ms per frame by stage."""
    import cv2

    before = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        t = _cpu()
        kernels.warm_up()  # compiled, or loaded from the cache: once a process
        warm = _cpu() - t
        t = _cpu()
        items = []
        with VideoReader(clip) as reader:
            for kind, item, pts in reader.packets():
                if kind == "video" and len(items) < frames:
                    items.append((item, pts))
        decode = _cpu() - t
        timing = SensorTiming(0.9)

        def correct_all() -> list:
            corr = Corrector(timing, config)
            done = []
            for i, (planes, _) in enumerate(items):
                done += corr.push(planes, float(i))
            return done + corr.flush()

        # A first pass faults in the memory the stages allocate: on this machine that
        # cost some stages three to five times their own time (docs/history/measurements.md), a
        # cost a long run pays once. Its total is printed; the stages are the second's.
        t = _cpu()
        correct_all()
        first = _cpu() - t
        with StageClock() as clock:
            t = _cpu()
            done = correct_all()
            correct = _cpu() - t
        t = _cpu()
        with VideoReader(clip) as reader:
            writer = VideoWriter.like(out, reader, EncodeOptions())
            for (planes, _), (_, pts) in zip(done, items, strict=True):
                writer.write(planes, pts)
            writer.close()
        encode = _cpu() - t
    finally:
        cv2.setNumThreads(before)
    n = len(items)
    print(f"compiled kernels loaded (once a process, not in the table): {1000 * warm:.0f} ms")
    rows = {"decode (PyAV, to planes)": decode}
    rows.update(clock.totals)
    rows["correction: not in a stage above"] = correct - sum(clock.totals.values())
    rows["encode (libx264 CRF 18 medium, its threads)"] = encode
    rows["first pass: the correction in all"] = first
    return {k: 1000 * v / n for k, v in rows.items()}


def profile(args: argparse.Namespace) -> None:
    unjello = [sys.executable, "-m", "unjello"]
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        for label, size, frames in (("1080p", (1920, 1080), args.frames),
                                    ("4K", (3840, 2160), args.k4_frames)):
            if frames < 1:  # --k4-frames 0: that size left out
                continue
            clip = d / f"clip_{label}.mp4"
            build_clip(clip, frames, size)
            stages = profile_stages(clip, d / "staged.mp4", frames)
            t = time.perf_counter()
            transcode(clip, d / "t0.mp4")
            t0 = time.perf_counter() - t
            t1, rss = timed([*unjello, "correct", str(clip), "-o", str(d / "t1.mp4"), "-q",
                             "-y"])
            print(f"\n{label} ({size[0]}x{size[1]}), {frames} frames, CPU ms per frame "
                  "(user + sys), one stage after another, single-threaded, the correction's "
                  "second pass:")
            first = stages.pop("first pass: the correction in all")
            for k, v in stages.items():
                print(f"  {k:46s} {v:8.1f}")
            work = sum(v for k, v in stages.items() if not k.startswith(("decode", "encode")))
            print(f"  {'correction in all':46s} {work:8.1f}")
            print(f"  {'(its first pass, memory faulted in)':46s} {first:8.1f}")
            print(f"wall in this run: plain transcode {t0:.1f} s, unjello correct {t1:.1f} s "
                  f"(peak RSS {rss:.0f} MB): {t1 / t0:.2f}x", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=300)
    ap.add_argument("--skip-memory", action="store_true")
    ap.add_argument("--rounds", type=int, default=3,
                    help="rounds of T0, T1 and T1 fast (the median round is reported)")
    ap.add_argument("--paper-frames", type=int, default=10,
                    help="frames timed with --method paper (it is slow at 1080p)")
    ap.add_argument("--profile", action="store_true",
                    help="CPU time per stage at 1080p and 4K instead (--frames, --k4-frames)")
    ap.add_argument("--k4-frames", type=int, default=20)
    ap.add_argument("--k4-memory-frames", type=int, default=60,
                    help="frames of the 4K clip whose peak memory is measured")
    args = ap.parse_args()
    if args.profile:
        profile(args)
        return
    unjello = [sys.executable, "-m", "unjello"]
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        clip = d / "clip1080.mp4"
        t = time.perf_counter()
        build_clip(clip, args.frames, (1920, 1080))
        print(f"built {args.frames} frames of 1920x1080 at 30 fps in "
              f"{time.perf_counter() - t:.0f} s", flush=True)
        # The ratios are measured round by round (T0, then T1 and T1 fast right after it)
        # and the median round is reported: a shared machine's speed drifts by 10-20 %
        # over minutes, which one round alone would fold into the ratio.
        rounds = []
        for k in range(args.rounds):
            t, c = time.perf_counter(), _self_cpu()
            transcode(clip, d / "t0.mp4")
            t0, c0 = time.perf_counter() - t, _self_cpu() - c
            t1, rss1, c1 = timed_cpu([*unjello, "correct", str(clip), "-o", str(d / "t1.mp4"),
                                      "-q", "-y"])
            tf, _, cf = timed_cpu([*unjello, "correct", str(clip), "-o", str(d / "tf.mp4"),
                                   "-q", "-y", "--preset", "fast"])
            rounds.append((t0, t1, tf, rss1, c0, c1, cf))
            print(f"round {k + 1}: T0 {t0:.1f} s, T1 {t1:.1f} s ({t1 / t0:.2f}), "
                  f"T1 fast {tf:.1f} s ({tf / t0:.2f})", flush=True)
        t0, t1, tf, rss1, c0, c1, cf = sorted(rounds, key=lambda r: r[1] / r[0])[
            len(rounds) // 2]
        per = 1000.0 / args.frames  # seconds of the clip -> ms a frame
        print("CPU (user + sys, all threads) of that round, whole process, and the cores it "
              "kept busy (CPU / wall):")
        for name, wall, cpu in (("T0 plain transcode", t0, c0), ("T1 default", t1, c1),
                                ("T1 --preset fast", tf, cf)):
            extra = "" if name.startswith("T0") else f", {per * (cpu - c0):+.0f} core-ms a frame"
            print(f"  {name:20s} {per * cpu:6.0f} core-ms a frame{extra}; "
                  f"{cpu / wall:.2f} of {os.cpu_count()} cores busy")
        print(f"median round of {len(rounds)} (by T1/T0):")
        print(f"T0 plain transcode (libx264 CRF 18 medium, audio copied): {t0:.1f} s "
              f"({args.frames / t0:.1f} fps)")
        print(f"T1 unjello correct (dense):                          {t1:.1f} s "
              f"({args.frames / t1:.1f} fps), T1/T0 = {t1 / t0:.2f}, peak RSS {rss1:.0f} MB")
        fast = sorted(r[2] / r[0] for r in rounds)
        print(f"T1 unjello correct --preset fast (camera only):       T1/T0 = "
              f"{fast[len(fast) // 2]:.2f} (median; rounds {', '.join(f'{x:.2f}' for x in fast)})",
              flush=True)
        npf = args.paper_frames
        if npf > 0:  # (--paper-frames 0: not timed)
            short = d / "clip_paper.mp4"
            cut(clip, short, npf)
            tp, _ = timed([*unjello, "correct", str(short), "-o", str(d / "tp.mp4"), "-q",
                           "--method", "paper"])
            print(f"unjello correct --method paper, first {npf} frames:     {tp:.1f} s "
                  f"({tp / npf:.2f} s/frame; {tp / npf / (t0 / args.frames):.1f}x the "
                  "transcode's time per frame)", flush=True)
        cut(clip, d / "clip60.mp4", 60)
        short = d / "clip60.mp4"
        # Correction stage alone, on the decoded YUV 4:2:0 planes `correct` works on.
        with VideoReader(short) as r:
            pictures = [item for kind, item, _ in r.packets() if kind == "video"]
        timing = SensorTiming(0.9)
        for name, config in (("default (dense, per pixel)", CorrectionConfig()),
                             ("--preset fast (camera only)", FAST)):
            stage_run(pictures[:3], timing, config)  # warm up
            # Best of three: other processes on a shared machine only ever slow it down.
            stage = min(stage_run(pictures, timing, config) for _ in range(3))
            print(f"correction stage alone, {name}, 1080p YUV planes in memory: "
                  f"{len(pictures) / stage:.1f} fps", flush=True)
        prof = cProfile.Profile()
        prof.enable()
        stage_run(pictures[:12], timing, CorrectionConfig())
        prof.disable()
        s = io.StringIO()
        pstats.Stats(prof, stream=s).sort_stats("tottime").print_stats(10)
        print("profile of the default correction stage (cProfile, by own time):")
        print("\n".join(ln for ln in s.getvalue().splitlines()[4:] if ln.strip())[:3000])
        if args.skip_memory:
            return
        for n in (100, 1000):
            small = d / f"m{n}.mp4"
            build_clip(small, n, (640, 360))
            sec, rss = timed([*unjello, "correct", str(small), "-o", str(d / f"o{n}.mp4"),
                              "-q", "--x264-preset", "veryfast"])
            print(f"peak RSS, 640x360, {n:4d} frames: {rss:.0f} MB ({sec:.0f} s)", flush=True)
        # 4K: both as child processes, so that both peaks are measured alike.
        k4 = d / "k4.mp4"
        n4 = args.k4_memory_frames
        build_clip(k4, n4, (3840, 2160))
        t0, rss0 = timed([sys.executable, "-c", TRANSCODE, str(k4), str(d / "tk4.mp4")])
        t1, rss1 = timed([*unjello, "correct", str(k4), "-o", str(d / "ok4.mp4"), "-q"])
        print(f"3840x2160, {n4} frames: plain transcode {t0:.1f} s, peak RSS {rss0:.0f} MB; "
              f"unjello correct {t1:.1f} s ({t1 / t0:.2f}x), peak RSS {rss1:.0f} MB "
              f"({rss1 - rss0:+.0f} MB)", flush=True)


if __name__ == "__main__":
    main()
