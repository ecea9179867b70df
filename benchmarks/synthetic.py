"""The simulated suite: per-scanline (or per-pixel) displacement error, paper vs dense.

Each case renders a rolling-shutter clip with known motion from ``skimage.data`` images
and reports the mean displacement error of each method (paper, dense as by default, dense
with ``--vibration on``) relative to no correction (lower is better), the PSNR of the corrected
frames against the global-shutter truth, and seconds per frame. Also times the dense
method at 640x480 and 1920x1080.

Usage::

    python benchmarks/synthetic.py [--frames 12] [--size 320x240] [--no-speed] [--edge-refine]
"""

from __future__ import annotations

import argparse
import time

import cv2
import numpy as np
from skimage import data

from unjello.config import CorrectionConfig
from unjello.io.roundtrip import degrade
from unjello.metrics import displacement_error, psnr, region_psnr
from unjello.motion.dense.method import DenseConfig
from unjello.pipeline import correct_frames
from unjello.simulate import Motion, simulate
from unjello.timing import SensorTiming

CASES = {
    # name: (motion, scene layers, exposure, degrade[, frames][, skimage.data image]
    #        [, "score=inside": the displacement error on the layer, else on the scene])
    "pan": (Motion("pan", speed=7.3), "planar", 0.0, False),
    "diagonal pan": (Motion("diagonal", speed=6.1), "planar", 0.0, False),
    "pan then stop": (Motion("stop", speed=7.0, stop_at=6.0), "planar", 0.0, False),
    "hand shake (1.5-9 Hz)": (Motion("shake"), "planar", 0.0, False),
    "drone jello (23-39 Hz)": (Motion("jello"), "planar", 0.0, False),
    # Vibration at 31 Hz barely changes between frames at 30 fps (it beats once a
    # second): resolving it takes about a second of footage on each side.
    "drone jello, 2 s clip": (Motion("jello"), "planar", 0.0, False, 60),
    "two-depth parallax": (Motion("pan", speed=5.0), "parallax", 0.0, False),
    # The moving object's clip without the object: what its background should score.
    "pan, 5 px/frame (no object)": (Motion("pan", speed=5.0), "planar", 0.0, False),
    "moving object (background)": (Motion("pan", speed=5.0), "object", 0.0, False),
    "pan + blur, noise, CRF 26": (Motion("pan", speed=7.3), "planar", 0.3, True),
    # Still, then 18 % of a 320 px frame per frame (vehicles, drones, whip pans), over
    # repetitive texture, where optical flow from zero locks onto an alias.
    "whip pan 18 %, grass": (Motion("whip", speed=57.6), "planar", 0.0, False, "grass"),
    "whip pan 18 %, gravel": (Motion("whip", speed=57.6), "planar", 0.0, False, "gravel"),
    "whip pan 18 %, brick": (Motion("whip", speed=57.6), "planar", 0.0, False, "brick"),
    "whip 18 % + blur, noise, CRF 26": (Motion("whip", speed=57.6), "planar", 0.3, True),
    # Still for 0.2 s, up to 560 px/s over 0.3 s (at 640 px; scaled to the frame),
    # exposure blur over 0.4 of a frame, noise and CRF 26: issue 31's pan from still.
    "pan from still + blur, noise, CRF 26": (Motion.from_rest(9.33, 0.0, 6.0, 9.0, 44.0),
                                             "planar", 0.4, True, 30),
    # Issue 38: flat poles 2.2 times as near as the background (parallax), the same pan
    # from still: followed by the flow, they keep their own motion (scored on all pixels).
    "poles in parallax, pan from still": (Motion.from_rest(9.33, 0.0, 6.0, 9.0, 44.0),
                                          "poles", 0.0, False, 30),
    # Spinning objects carried with a panning camera, scored on their own pixels (PSNR:
    # around them) and on the background (PSNR: the whole frame).
    "propeller 6 rev/s (blades)": (Motion("pan", speed=5.0), "propeller", 0.0, False,
                                   "score=inside"),
    "propeller 6 rev/s (background)": (Motion("pan", speed=5.0), "propeller", 0.0, False),
    "wheel 4 rev/s (wheel)": (Motion("pan", speed=5.0), "wheel", 0.0, False, "score=inside"),
    "wheel 4 rev/s (background)": (Motion("pan", speed=5.0), "wheel", 0.0, False),
}


METHODS = {"paper": CorrectionConfig(method="paper"), "dense": CorrectionConfig(),
           "vibration": CorrectionConfig(dense=DenseConfig(vibration="on"))}


def run_case(name: str, frames: int, size: tuple[int, int]) -> dict:
    motion, layers, exposure, bad, *rest = CASES[name]
    frames = next((r for r in rest if isinstance(r, int)), frames)
    names = [r for r in rest if isinstance(r, str) and not r.startswith("score=")]
    inside = "score=inside" in rest
    scene = getattr(data, names[0] if names else "astronaut")()
    if scene.ndim == 2:
        scene = np.dstack([scene] * 3)
    timing = SensorTiming(1.0)
    sim = list(simulate(scene, motion, timing, frames, size=size, layers=layers,
                        exposure=exposure, layer_image=data.coffee()))
    rolling = [s.rolling for s in sim]
    if bad:
        rolling = degrade(rolling)
    masks = [None if s.layer is None or layers in ("parallax", "poles") else
             (s.layer != 0 if inside else s.layer == 0) for s in sim]
    unc = np.mean([displacement_error(None, s.motion, m) for s, m in zip(sim, masks, strict=True)])

    def score(images: list[np.ndarray]) -> float:
        """Mean PSNR of ``images``: whole frames (12 px margin), or around the object.

        Around the object: its pixels in the rolling-shutter frame, grown by 12 px.
        """
        if not inside:
            return float(np.mean([psnr(o, s.truth, 12) for o, s in zip(images, sim,
                                                                         strict=True)]))
        grow = np.ones((25, 25), np.uint8)
        return float(np.mean([region_psnr(o, s.truth, cv2.dilate(
            (s.layer != 0).astype(np.uint8), grow).astype(bool))
            for o, s in zip(images, sim, strict=True)]))

    row = {"case": name, "frames": frames, "uncorrected_px": unc, "psnr_in": score(rolling)}
    for method, config in METHODS.items():
        t0 = time.perf_counter()
        out, traj = correct_frames(rolling, timing, config=config)
        row[f"{method}_s"] = (time.perf_counter() - t0) / frames
        err = np.mean([displacement_error(f, s.motion, m)
                       for f, s, m in zip(traj.frames, sim, masks, strict=True)])
        row[f"{method}_ratio"] = err / unc
        row[f"{method}_psnr"] = score(out)
    return row


def speed(size: tuple[int, int], frames: int = 8) -> float:
    sim = [s.rolling for s in simulate(data.astronaut(), Motion("pan", speed=6.0),
                                       SensorTiming(1.0), frames, size=size)]
    correct_frames(sim[:3], SensorTiming(1.0))  # warm up
    t0 = time.perf_counter()
    correct_frames(sim, SensorTiming(1.0))
    return (time.perf_counter() - t0) / frames


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=12)
    ap.add_argument("--size", default="320x240")
    ap.add_argument("--no-speed", action="store_true")
    ap.add_argument("--edge-refine", action="store_true",
                    help="dense columns with --edge-refine (motion boundaries refined)")
    args = ap.parse_args()
    if args.edge_refine:
        METHODS["dense"] = CorrectionConfig(dense=DenseConfig(edge_refine=True))
        METHODS["vibration"] = CorrectionConfig(dense=DenseConfig(edge_refine=True,
                                                                  vibration="on"))
    size = tuple(int(v) for v in args.size.split("x"))
    print(f"{args.frames} frames of {size[0]}x{size[1]}, readout 1.0; error = mean "
          "displacement error / uncorrected (lower is better)")
    print("columns: paper, dense (default: --vibration auto), dense --vibration on; error "
          "ratios, then PSNR (dB)")
    print(f"{'case':30} {'frames':>6} {'uncorr px':>9} {'paper':>7} {'dense':>7} {'vibr.':>7} "
          f"{'PSNR in':>8} {'paper':>7} {'dense':>7} {'vibr.':>7} {'dense s/f':>9}")
    for name in CASES:
        r = run_case(name, args.frames, size)  # type: ignore[arg-type]
        print(f"{name:30} {r['frames']:6d} {r['uncorrected_px']:9.3f} {r['paper_ratio']:7.3f} "
              f"{r['dense_ratio']:7.3f} {r['vibration_ratio']:7.3f} {r['psnr_in']:8.2f} "
              f"{r['paper_psnr']:7.2f} {r['dense_psnr']:7.2f} {r['vibration_psnr']:7.2f} "
              f"{r['dense_s']:9.2f}", flush=True)
    if not args.no_speed:
        for wh in ((640, 480), (1920, 1080)):
            s = speed(wh)
            print(f"dense method, correction stage in memory, {wh[0]}x{wh[1]}: "
                  f"{s:.3f} s/frame ({1 / s:.1f} fps)")


if __name__ == "__main__":
    main()
