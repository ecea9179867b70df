"""PSNR/SSIM of `unjello correct` on the research pairs in ../shared/data/pairs.

For every pair folder (rs_0, rs_1 -> corrected frame 1) of Fastec-RS and Carla-RS, run
the real command line on a two-frame folder and score the corrected ``rs_1`` against
the global-shutter truth (``gs_1_m`` for the middle-scanline reference, ``gs_1_f`` with
``--reference first``), whole image, RGB, 0-255, skimage.metrics. The uncorrected row
scores ``rs_1`` itself.

With the Carla set and the middle reference it also scores two frames of a clip:
``sequences/carla_town05_rs`` frames 0005 and 0006 are ``carla/pair_03``'s ``rs_0`` and
``rs_1``, so that pair's ``gs_0_m`` and ``gs_1_m`` are their truth, corrected inside the
10-frame clip (both neighbours) and as a two-frame folder.

Usage::

    python benchmarks/pairs.py [--method paper] [--reference middle|first] [--readout 1.0]
                               [--sets fastec,carla] [--json]
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from unjello.io.frames import read_image
from unjello.metrics import psnr, ssim

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "pairs"


def run_pair(pair: Path, work: Path, args: argparse.Namespace) -> dict | None:
    truth_name = "gs_1_m.png" if args.reference == "middle" else "gs_1_f.png"
    truth_path = pair / truth_name
    if not truth_path.exists():
        return None
    src = work / pair.name
    src.mkdir()
    for name in ("rs_0.png", "rs_1.png"):
        shutil.copyfile(pair / name, src / name)
    out = work / f"{pair.name}_out"
    cmd = [sys.executable, "-m", "unjello", "correct", str(src), "-o", str(out), "-q",
           "--readout", str(args.readout), "--reference", args.reference,
           "--method", args.method, *args.extra]
    t0 = time.perf_counter()
    res = subprocess.run(cmd, capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    if res.returncode != 0:
        raise SystemExit(f"{pair}: unjello failed: {res.stderr.strip()}")
    truth = read_image(truth_path)
    rs = read_image(pair / "rs_1.png")
    fixed = read_image(out / "rs_1.png")
    return {"pair": pair.name, "psnr_in": psnr(rs, truth), "ssim_in": ssim(rs, truth),
            "psnr": psnr(fixed, truth), "ssim": ssim(fixed, truth), "seconds": seconds}


def run_clip(work: Path, args: argparse.Namespace) -> dict | None:
    """Frames 0005 and 0006 of the Carla town clip, in the clip and as a pair."""
    clip = SHARED.parent / "sequences" / "carla_town05_rs"
    truth = SHARED / "carla" / "pair_03"
    if not clip.is_dir() or not (truth / "gs_0_m.png").exists():
        return None
    pair = work / "clip_pair"
    pair.mkdir()
    for name in ("0005_rs.png", "0006_rs.png"):
        shutil.copyfile(clip / name, pair / name)
    row = {}
    for label, src in (("clip", clip), ("pair", pair)):
        out = work / f"{label}_out"
        cmd = [sys.executable, "-m", "unjello", "correct", str(src), "-o", str(out), "-q",
               "--readout", str(args.readout), "--method", args.method, *args.extra]
        res = subprocess.run(cmd, capture_output=True, text=True)
        if res.returncode != 0:
            raise SystemExit(f"{src}: unjello failed: {res.stderr.strip()}")
        row[label] = [psnr(read_image(out / f"000{k + 5}_rs.png"),
                           read_image(truth / f"gs_{k}_m.png")) for k in (0, 1)]
    row["uncorrected"] = [psnr(read_image(clip / f"000{k + 5}_rs.png"),
                               read_image(truth / f"gs_{k}_m.png")) for k in (0, 1)]
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--method", default="paper")
    ap.add_argument("--reference", default="middle", choices=["middle", "first"])
    ap.add_argument("--readout", default="1.0")
    ap.add_argument("--sets", default="fastec,carla")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("extra", nargs="*", help="more options for `unjello correct` after --")
    args = ap.parse_args()
    if not SHARED.is_dir():
        raise SystemExit(f"skipped: {SHARED} is absent (the shared data lives beside the repo)")
    summary = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.sets.split(","):
            rows = []
            for pair in sorted((SHARED / name).iterdir()):
                work = Path(tmp) / name
                work.mkdir(exist_ok=True)
                row = run_pair(pair, work, args)
                if row:
                    rows.append(row)
                    if not args.json:
                        print(f"  {name}/{row['pair']}: {row['psnr_in']:6.2f} -> "
                              f"{row['psnr']:6.2f} dB  SSIM {row['ssim_in']:.3f} -> "
                              f"{row['ssim']:.3f}  ({row['seconds']:.1f} s)", flush=True)
            summary[name] = {
                "pairs": len(rows),
                **{k: float(np.mean([r[k] for r in rows]))
                   for k in ("psnr_in", "ssim_in", "psnr", "ssim", "seconds")},
                "rows": rows,
            }
        clip = (run_clip(Path(tmp), args) if "carla" in args.sets.split(",")
                and args.reference == "middle" else None)
    if clip is not None:
        summary["carla_clip"] = clip
    if args.json:
        print(json.dumps(summary, indent=1))
        return
    ref = "gs_1_m" if args.reference == "middle" else "gs_1_f"
    print(f"\nmethod={args.method} reference={args.reference} (truth {ref}) "
          f"readout={args.readout}")
    print(f"{'set':8} {'pairs':>5} {'PSNR in':>8} {'PSNR out':>9} {'SSIM in':>8} "
          f"{'SSIM out':>9} {'s/pair':>7}")
    for name, s in summary.items():
        if name == "carla_clip":
            continue
        print(f"{name:8} {s['pairs']:5d} {s['psnr_in']:8.2f} {s['psnr']:9.2f} "
              f"{s['ssim_in']:8.3f} {s['ssim']:9.3f} {s['seconds']:7.1f}")
    if clip is not None:
        print("carla_town05_rs frames 0005 / 0006 against pair_03's gs_0_m / gs_1_m: "
              f"uncorrected {clip['uncorrected'][0]:.2f} / {clip['uncorrected'][1]:.2f}, "
              f"in the 10-frame clip {clip['clip'][0]:.2f} / {clip['clip'][1]:.2f}, "
              f"as a pair {clip['pair'][0]:.2f} / {clip['pair'][1]:.2f} dB")


if __name__ == "__main__":
    main()
