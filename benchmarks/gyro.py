"""The gyro method: simulated clips with their logs, and the real hand-held phone clip.

1. Simulated (``unjello.simulate``, 320x240, readout 0.9, 60 frames): shake, a pan, drone
   jello, each with a 400 Hz gyro log from the same motion (focal 8x the width, so the
   rotation is close to the simulator's translation), white noise 0.002 rad/s, the gyro
   mounted with other axes (``yZx``) and its clock 12.345 s ahead. Reports the calibration
   found and the mean displacement error relative to no correction, gyro vs dense. (A
   steady pan's rotation is the same at every offset, and the simulated jello's 23, 31
   and 39 Hz repeat every second: their offsets are found up to that.)
2. The correction stage at 1920x1080 (90 frames in memory): frames per second, with the
   calibration (DIS flow of the first 60 frames and the search) and with it given.
3. ``../shared/data/sequences/phone_gyro`` (103 frames of a hand-held phone in a car):
   the calibration against the published intrinsics (focal 573.85 px) and frame stamps,
   and the median residual of a homography fitted to the flow between consecutive frames
   above the dashboard (lower: closer to one rigid rotation; parallax keeps it above 0).

Usage::

    python benchmarks/gyro.py [--skip-real]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
from skimage import data

from unjello.config import CorrectionConfig
from unjello.gyrolog import GyroConfig, axes_matrix
from unjello.io.frames import list_frames, read_image
from unjello.io.sidecars import write_gyro
from unjello.metrics import displacement_error
from unjello.pipeline import correct_frames
from unjello.simulate import Motion, gyro_samples, simulate
from unjello.timing import SensorTiming

PHONE = Path(__file__).resolve().parents[2] / "shared" / "data" / "sequences" / "phone_gyro"


def simulated(case: str, motion: Motion, work: Path, n: int = 60,
              size: tuple[int, int] = (320, 240)) -> None:
    timing = SensorTiming(0.9)
    sim = list(simulate(data.astronaut(), motion, timing, n, size=size))
    focal = 8.0 * size[0]
    t, rates = gyro_samples(motion, focal, n / motion.fps, axes=axes_matrix("yZx"),
                            start=12.345, noise=0.002)
    log = work / f"{case}.csv"
    write_gyro(log, t, rates)
    frames = [s.rolling for s in sim]
    unc = np.mean([displacement_error(None, s.motion) for s in sim])
    row = [f"{case:10} {unc:9.3f}"]
    for name, cfg in (("gyro", CorrectionConfig(method="gyro", gyro=GyroConfig(path=str(log)))),
                      ("dense", CorrectionConfig())):
        t0 = time.perf_counter()
        _, traj = correct_frames(frames, timing, config=cfg)
        sec = (time.perf_counter() - t0) / n
        err = np.mean([displacement_error(f, s.motion)
                       for f, s in zip(traj.frames, sim, strict=True)])
        row.append(f"{err / unc:7.3f} {sec:6.3f}")
        if name == "gyro":
            note = traj.frames[0].note
    print(" ".join(row) + f"   {note} (true: yZx, 12345.0 ms, {focal:.0f} px)", flush=True)


def stage_speed(work: Path, n: int = 90) -> None:
    motion = Motion("shake", fps=30.0)
    timing = SensorTiming(0.9)
    size = (1920, 1080)
    frames = [s.rolling for s in simulate(data.astronaut(), motion, timing, n, size=size)]
    t, rates = gyro_samples(motion, 8.0 * size[0], n / 30)
    log = work / "hd.csv"
    write_gyro(log, t, rates)
    known = GyroConfig(path=str(log), axes="XYZ", offset=0.0, focal=8.0 * size[0])
    for label, cfg in (("calibrated on its first 60 frames", GyroConfig(path=str(log))),
                       ("calibration given", known)):
        t0 = time.perf_counter()
        correct_frames(frames, timing, config=CorrectionConfig(method="gyro", gyro=cfg))
        sec = (time.perf_counter() - t0) / n
        print(f"gyro, 1920x1080, {label}: {sec * 1000:.1f} ms/frame ({1 / sec:.1f} fps)",
              flush=True)


def homography_residual(frames: list[np.ndarray]) -> np.ndarray:
    """Median residual (px at 400 px wide) of a homography fitted to consecutive flows."""
    out, prev = [], None
    ys, xs = np.mgrid[10:200:5, 10:390:5]
    src = np.stack([xs.ravel(), ys.ravel()], -1).astype(np.float32)
    for f in frames:
        g = cv2.cvtColor(f[..., :3], cv2.COLOR_RGB2GRAY)[:420]  # above the dashboard
        g = cv2.resize(g, (400, 210), interpolation=cv2.INTER_AREA)
        if prev is not None:
            flow = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM).calc(
                g, prev, None)
            dst = src + flow[ys.ravel(), xs.ravel()]
            hom, _ = cv2.findHomography(src, dst, cv2.RANSAC, 1.0)
            fit = cv2.perspectiveTransform(src[None], hom)[0]
            out.append(np.median(np.hypot(*(fit - dst).T)))
        prev = g
    return np.array(out)


def real() -> None:
    if not PHONE.is_dir():
        print(f"skipped the phone clip: {PHONE} is absent")
        return
    frames = [read_image(f) for f in list_frames(PHONE / "reshape")]
    base = homography_residual(frames)
    stamp = np.loadtxt(PHONE / "framestamp.txt")[99]
    print(f"phone_gyro: {len(frames)} frames 800x600; published focal 573.85 px; readouts "
          "1.0 (33.3 ms, the publishing code's) and 0.45 (15.1 ms, its alternative)")
    for readout in (1.0, 0.45):
        timing = SensorTiming(readout)
        cfg = CorrectionConfig(method="gyro", gyro=GyroConfig(path=str(PHONE / "gyro.txt")))
        t0 = time.perf_counter()
        gyro_out, traj = correct_frames(frames, timing, config=cfg)
        sec = (time.perf_counter() - t0) / len(frames)
        dense_out, _ = correct_frames(frames, timing)
        note = traj.frames[0].note
        offset = float(note.split("offset ")[1].split(" ms")[0]) / 1000
        print(f"readout {readout}: {note}; {sec * 1000:.0f} ms/frame; middle row's time - "
              f"frame 99's stamp: {1000 * (offset + readout / 2 / 30 - stamp):+.1f} ms")
        mag = np.array([np.abs(f.displacement).max() for f in traj.frames])
        pair = np.maximum(mag[1:], mag[:-1])
        res = {"gyro": homography_residual(gyro_out), "dense": homography_residual(dense_out)}
        for thr in (0.0, 2.0):
            s = pair > thr
            print(f"  pairs with a gyro correction above {thr:.0f} px ({s.sum():3d}): "
                  f"homography residual uncorrected {base[s].mean():.3f}, "
                  f"gyro {res['gyro'][s].mean():.3f}, dense {res['dense'][s].mean():.3f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--skip-real", action="store_true")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        print("simulated, 60 frames 320x240, readout 0.9; error / uncorrected, s/frame")
        print(f"{'case':10} {'uncorr px':>9} {'gyro':>7} {'s/f':>6} {'dense':>7} {'s/f':>6}")
        for case, motion in (("shake", Motion("shake", fps=30.0)),
                             ("pan", Motion("pan", fps=30.0, speed=6.0)),
                             ("jello", Motion("jello", fps=30.0))):
            simulated(case, motion, work)
        stage_speed(work)
    if not args.skip_real:
        real()


if __name__ == "__main__":
    main()
