"""The footage's motion as a Gyroflow project: what the editors' plugins would apply.

1. Simulated clips (``unjello.simulate``, 480x360, readout 0.9, 60 frames, a lens of
   known focal length): pans, hand shake and drone jello, corrected by the dense method
   (camera trajectory only) and exported (:func:`unjello.exports.gyroflow.camera_rates`). The
   ``.gcsv`` is read back by ``telemetry_parser`` and Gyroflow's rule (``No smoothing``:
   each row turned by its rotation relative to the frame's middle row, re-implemented
   from Gyroflow's source in :func:`unjello.exports.gyroflow.gyroflow_displacement`) gives a
   per-row displacement. Printed: its mean difference from the dense method's own
   (px a scanline), and the error against the truth of both (a share of the uncorrected).
2. The round trip: ``--method gyro --gyro clip.gcsv`` on the same clip against the
   camera-only correction it was exported from (px a scanline).
3. ``../shared/data/sequences/phone_gyro`` (103 frames, 800x600, a real phone's gyro):
   the rates exported from the footage alone (published focal 573.85 px) against the
   phone's own gyro in the camera's axes and on the clip's clock (unjello's gyro
   calibration of it), both averaged over a frame interval: correlation per axis, from
   the default run and from ``--camera-only``.

Usage::

    python benchmarks/gyroflow.py [--skip-real]
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

import numpy as np
from skimage import data

from unjello.config import CorrectionConfig
from unjello.exports.gyroflow import (
    ProjectLens,
    camera_rates,
    export_project,
    gyroflow_displacement,
)
from unjello.gyrolog import GyroConfig
from unjello.io.frames import list_frames, read_image
from unjello.io.sidecars import read_gyro
from unjello.metrics import displacement_error
from unjello.motion.gyro.method import GyroMethod
from unjello.pipeline import correct_frames
from unjello.simulate import Motion, simulate
from unjello.timing import SensorTiming
from unjello.trajectory import FrameMotion

PHONE = Path(__file__).resolve().parents[2] / "shared" / "data" / "sequences" / "phone_gyro"
CAMERA_ONLY = CorrectionConfig().with_options(camera_only=True)


def simulated(case: str, motion: Motion, work: Path, n: int = 60,
              size: tuple[int, int] = (480, 360)) -> None:
    import telemetry_parser

    timing, fps, focal = SensorTiming(0.9), motion.fps, 1.2 * size[0]
    sim = list(simulate(data.astronaut(), motion, timing, n, size=size))
    frames = [s.rolling for s in sim]
    _, traj = correct_frames(frames, timing, config=CAMERA_ONLY)
    lens = ProjectLens(focal)
    (gcsv, proj), _ = export_project(traj, work / f"{case}.gyroflow", video=work / "c.mp4",
                                     fps=fps, lens=lens, frames=n)
    imu = telemetry_parser.Parser(str(gcsv)).normalized_imu()
    t_ms = np.array([s["timestamp_ms"] for s in imu])
    gyro = np.array([s["gyro"] for s in imu])
    offset = float(json.loads(proj.read_text())["offsets"]["0"])
    rule = gyroflow_displacement(t_ms, gyro, offset_ms=offset, fps=fps,
                                 readout_ms=timing.readout * 1000 / fps,
                                 size=(size[1], size[0]), focal=focal, frames=np.arange(n))
    own = np.stack([f.displacement for f in traj.frames])
    unc = np.mean([displacement_error(None, s.motion) for s in sim])
    e_own = np.mean([displacement_error(f, s.motion) for f, s in zip(traj.frames, sim,
                                                                     strict=True)])
    e_rule = np.mean([displacement_error(FrameMotion(f.index, f.start, d, f.velocity),
                                         s.motion)
                      for f, d, s in zip(traj.frames, rule, sim, strict=True)])
    # The round trip: the gyro method on the log, its lens and clock as the log states.
    cal = GyroConfig(path=str(gcsv), axes="XYZ", offset=0.0, focal=focal)
    _, back = correct_frames(frames, timing, config=CorrectionConfig(method="gyro", gyro=cal),
                             fps=fps)
    trip = np.stack([f.displacement for f in back.frames])
    print(f"{case:8} {np.abs(own).mean():9.3f} {np.abs(rule - own).mean():10.4f} "
          f"{unc:8.3f} {e_own / unc:7.3f} {e_own:7.4f} {e_rule / unc:7.3f} {e_rule:7.4f} "
          f"{np.abs(trip - own).mean():10.4f}", flush=True)


def rule_gap(traj, focal: float, fps: float) -> float:
    """Mean |Gyroflow's rule on the exported log - unjello's rows|, px a scanline."""
    import telemetry_parser

    with tempfile.TemporaryDirectory() as tmp:
        (gcsv, proj), _ = export_project(traj, Path(tmp) / "c.gyroflow", video="c.mp4",
                                         fps=fps, lens=ProjectLens(focal), frames=len(traj))
        imu = telemetry_parser.Parser(str(gcsv)).normalized_imu()
        offset = float(json.loads(proj.read_text())["offsets"]["0"])
    w, h = traj.size
    rule = gyroflow_displacement(np.array([s["timestamp_ms"] for s in imu]),
                                 np.array([s["gyro"] for s in imu]), offset_ms=offset,
                                 fps=fps, readout_ms=traj.timing.readout * 1000 / fps,
                                 size=(h, w), focal=focal, frames=np.arange(len(traj)))
    own = np.stack([f.camera_displacement for f in traj.frames])
    return float(np.abs(rule - own).mean())


def phone() -> None:
    if not PHONE.is_dir():
        print(f"skipped the phone clip: {PHONE} is absent")
        return
    fps, timing, focal = 30.0, SensorTiming(1.0), 573.85
    frames = [read_image(f) for f in list_frames(PHONE / "reshape")]
    log = read_gyro(PHONE / "gyro.txt")
    method = GyroMethod(timing, log, GyroConfig(sync_frames=60), fps=fps)
    for i, f in enumerate(frames[:60]):
        method.push(f.mean(axis=-1).astype(np.float32), float(i))
    method.flush()
    cal = method.calibration
    print(f"phone_gyro: {len(frames)} frames, {cal.describe()}")
    print("the footage's exported rates vs the phone's gyro, averaged over a frame interval:")
    for name, config in (("default", CorrectionConfig()), ("--camera-only", CAMERA_ONLY)):
        _, traj = correct_frames(frames, timing, config=config)
        t, rate = camera_rates(traj, ProjectLens(focal), fps)
        print(f"  {name:13} Gyroflow's rule vs unjello's own rows: "
              f"{rule_gap(traj, focal, fps):.4f} px a scanline (mean)")
        real = np.stack([np.interp(t + cal.offset, log.time, (log.rate @ cal.axes.T)[:, i])
                         for i in range(3)], axis=1)
        per_frame = round(t.size / (t[-1] * fps))
        box = np.ones(per_frame) / per_frame
        for i, axis in enumerate(("pitch (x)", "yaw (y)", "roll (z)")):
            a = np.convolve(rate[:, i], box, "valid")
            b = np.convolve(real[:, i], box, "valid")
            r = np.corrcoef(a, b)[0, 1]
            print(f"  {name:13} {axis:9}: correlation {r:.3f}; rms rad/s exported "
                  f"{a.std():.3f}, gyro {b.std():.3f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--skip-real", action="store_true")
    args = ap.parse_args()
    print("simulated, 60 frames 480x360, readout 0.9, focal 576 px; px a scanline; error "
          "against the truth as a share of the uncorrected (and in px)")
    print(f"{'case':8} {'|camera|':>9} {'rule-own':>10} {'uncorr':>8} {'own':>7} {'px':>7} "
          f"{'rule':>7} {'px':>7} {'roundtrip':>10}")
    with tempfile.TemporaryDirectory() as tmp:
        for case, motion in (("pan", Motion("pan", fps=30.0, speed=8.0)),
                             ("fast pan", Motion("pan", fps=30.0, speed=30.0)),
                             ("shake", Motion("shake", fps=30.0)),
                             ("jello", Motion("jello", fps=30.0))):
            simulated(case, motion, Path(tmp))
    if not args.skip_real:
        phone()


if __name__ == "__main__":
    main()
