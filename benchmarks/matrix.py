"""The matrix of simulated clips: every case scored with the default settings.

Builds the clips of :func:`unjello.simulate.matrix.cases` (pans, hand shake, walks, drone
jello, a still camera, cuts, fades and flashes, over photos, sharp textures, a flat sky
behind poles, low texture, parallax, spinners and moving objects; readouts 0.3-1.0,
24-60 fps, 320x180 to 1280x720, CRF 14-28, noise, exposure blur, the four scan
directions), corrects each with the default settings and prints a line a case (error
relative to uncorrected, PSNR against the truth in and out, CPU ms a frame), then a table
per kind (median, worst). ``--compare BASELINE.json`` lists every case worse than the
baseline by more than 0.01x or past 1.0x, and exits 1 if there is one.

Usage::

    python benchmarks/matrix.py [--jobs 2] [--kind jello] [--only NAME ...] [--slice]
                                [--out matrix.json] [--compare benchmarks/matrix_baseline.json]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from unjello.simulate.matrix import TARGETS, Case, ci_slice, score
from unjello.simulate.matrix import cases as all_cases

WORSE = 0.01  # a case that got worse by more than this (error ratio) is listed


VIBRATION = "auto"  # --vibration


def correct(frames, timing, fps):
    from unjello.config import CorrectionConfig
    from unjello.motion.dense.method import DenseConfig
    from unjello.pipeline import correct_frames

    config = CorrectionConfig(dense=DenseConfig(vibration=VIBRATION))
    return correct_frames(frames, timing, config=config, fps=fps)


def _one(job: tuple[Case, str]) -> dict:
    import cv2

    global VIBRATION
    case, VIBRATION = job
    cv2.setNumThreads(1)  # one core a case: the jobs share the machine evenly
    return score(case, correct)


def line(r: dict) -> str:
    extra = ""
    if "background_out" in r:
        extra += f"  background {r['background_in']:.2f} -> {r['background_out']:.2f} dB"
    if "cut_db" in r:
        extra += f"  beside the cut {r['cut_db']:+.2f} dB vs apart"
    if r.get("vibration"):
        extra += "  [vibration]"
    return (f"{r['case']:34} {r['frames']:4d} {r['ratio']:7.3f} {r['psnr_in']:7.2f} "
            f"{r['psnr_out']:7.2f} {r['core_ms']:8.1f}{extra}")


def tables(rows: list[dict]) -> None:
    print(f"\n{'kind':8} {'cases':>5} {'median':>7} {'worst':>7} {'target':>7} "
          f"{'PSNR in':>8} {'out':>7} {'core-ms/f':>9}")
    for kind, target in TARGETS.items():
        rs = [r for r in rows if r["kind"] == kind]
        if not rs:
            continue
        ratios = [r["ratio"] for r in rs]
        print(f"{kind:8} {len(rs):5d} {np.median(ratios):7.3f} {max(ratios):7.3f} "
              f"{target:7.2f} {np.median([r['psnr_in'] for r in rs]):8.2f} "
              f"{np.median([r['psnr_out'] for r in rs]):7.2f} "
              f"{np.median([r['core_ms'] for r in rs]):9.1f}")


def compare(rows: list[dict], baseline: Path) -> int:
    base = {r["case"]: r for r in json.loads(baseline.read_text())["cases"]}
    bad = []
    for r in rows:
        b = base.get(r["case"])
        if r["ratio"] > 1.0 or (b is not None and r["ratio"] > b["ratio"] + WORSE):
            bad.append((r, b))
    print(f"\ncompared with {baseline}: {len(bad)} case(s) worse by more than {WORSE}x "
          "or past 1.0x")
    for r, b in bad:
        was = f"{b['ratio']:.3f}" if b else "new"
        print(f"  {r['case']:34} {was} -> {r['ratio']:.3f}")
    return 1 if bad else 0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=2, help="cases corrected at once (processes)")
    ap.add_argument("--kind", action="append", help="only these kinds")
    ap.add_argument("--only", nargs="*", help="only these cases, by name (or a prefix)")
    ap.add_argument("--slice", action="store_true", help="the test suite's cases only")
    ap.add_argument("--vibration", choices=("auto", "on", "off"), default="auto",
                    help="the dense method's vibration setting (default: auto)")
    ap.add_argument("--out", type=Path, help="write the rows as JSON")
    ap.add_argument("--compare", type=Path, help="a baseline JSON written by --out")
    args = ap.parse_args()
    todo = ci_slice() if args.slice else all_cases()
    if args.kind:
        todo = [c for c in todo if c.kind in args.kind]
    if args.only:
        todo = [c for c in todo if any(c.name.startswith(o) for o in args.only)]
    print(f"{len(todo)} cases; error = displacement error / uncorrected (lower is better), "
          "PSNR against the global-shutter truth, CPU ms of all threads a frame")
    print(f"{'case':34} {'n':>4} {'error':>7} {'PSNR in':>7} {'out':>7} {'core-ms/f':>8}")
    t0 = time.perf_counter()
    rows = []
    with ProcessPoolExecutor(max(1, args.jobs)) as pool:
        for r in pool.map(_one, [(c, args.vibration) for c in todo]):
            print(line(r), flush=True)
            rows.append(r)
    tables(rows)
    print(f"\n{len(rows)} cases in {time.perf_counter() - t0:.0f} s")
    if args.out:
        args.out.write_text(json.dumps({"cases": rows}, indent=1) + "\n")
    if args.compare:
        sys.exit(compare(rows, args.compare))


if __name__ == "__main__":
    main()
