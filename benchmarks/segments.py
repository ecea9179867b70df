"""One long clip in segments on a local Dask and Ray cluster, against one process.

Builds a simulated 1080p30 clip with audio (``--frames``, a keyframe every 2 s), then in
one run: `unjello correct` as one process, and with ``--segments 3 --executor dask`` and
``--executor ray`` (``--workers`` local worker processes). For each segmented output:
wall time and its ratio to the one-process run (the overhead of segmenting on this
machine), frame count, pts and audio packets against the source, and the mean absolute
difference of every frame from the one-process output (grey levels; both lossy x264, so
this includes two encoders' different choices; with ``--crf 0`` the frames are the
same, ``tests/run/test_segments.py``).

Usage::

    python benchmarks/segments.py [--frames 900] [--workers 2] [--crf 18]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import av
import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from speed import build_clip  # noqa: E402


def grey_frames(path: Path) -> list[np.ndarray]:
    with av.open(str(path)) as c:
        return [f.to_ndarray(format="gray") for f in c.decode(video=0)]


def stream_facts(path: Path) -> tuple[list[int], int]:
    with av.open(str(path)) as c:
        pts = sorted(p.pts for p in c.demux(video=0) if p.pts is not None)
    with av.open(str(path)) as c:
        audio = sum(1 for p in c.demux(audio=0) if p.dts is not None) if c.streams.audio else 0
    return pts, audio


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=900)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--crf", type=int, default=18)
    args = ap.parse_args()
    unjello = [sys.executable, "-m", "unjello", "correct"]
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        clip = d / "long.mp4"
        build_clip(clip, args.frames, (1920, 1080))
        src_pts, src_audio = stream_facts(clip)
        runs = {}
        for name, extra in (("one process", []),
                            ("dask, 3 segments", ["--segments", "3", "--executor", "dask"]),
                            ("ray, 3 segments", ["--segments", "3", "--executor", "ray"])):
            out = d / f"{name.split(',')[0].replace(' ', '_')}.mp4"
            workers = ["--workers", str(args.workers)] if extra else []
            t = time.perf_counter()
            subprocess.run([*unjello, str(clip), "-o", str(out), "-q", "-y", "--crf",
                            str(args.crf), *extra, *workers], check=True,
                           stderr=subprocess.DEVNULL)
            runs[name] = (out, time.perf_counter() - t)
            print(f"{name}: {runs[name][1]:.1f} s", flush=True)
        one = grey_frames(runs["one process"][0])
        print(f"\n{args.frames} frames 1920x1080, {args.workers} workers, CRF {args.crf}; source: "
              f"{len(src_pts)} frames, {src_audio} audio packets")
        print("run                 wall s  /one   frames  pts=src  audio  MAD mean  MAD max")
        for name, (out, sec) in runs.items():
            pts, audio = stream_facts(out)
            frames = grey_frames(out)
            mad = [float(np.abs(a.astype(np.float32) - b).mean())
                   for a, b in zip(frames, one, strict=True)]
            print(f"{name:18s} {sec:7.1f} {sec / runs['one process'][1]:6.2f} {len(frames):8d} "
                  f"{str(pts == src_pts):>8s} {audio:6d} {np.mean(mad):9.3f} {max(mad):8.3f}")


if __name__ == "__main__":
    main()
