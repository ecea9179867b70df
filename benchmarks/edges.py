"""The frame's edge in fast motion (issue 38): PSNR of the strip, the interior, the frame.

During a fast pan the reference instant shows, at the side the camera turns towards or
away from, content that the frame's own scanlines never saw: the output pixels whose
true source lies outside the frame (the *strip*). A neighbouring frame saw most of it.
This renders simulated clips (10 frames) and pairs (2 frames) at 10-40 % of the width a
frame, readouts 0.4-1.0, with straight flat poles passing in front 1.3 times as near as
the background (parallax; ``--near``), and prints, per case, the PSNR (dB) against the
global-shutter truth of:

- the strip (pixels whose true source lies outside the frame), split into the pixels
  the previous frame saw (rows read after the reference), those the next saw (rows read
  before it) and those none saw (a pair's or a clip's first frame's late rows, its last
  frame's early ones);
- the interior (every other pixel, 8 px from the frame's border);
- the whole frame (8 px margin);

for the input and the default correction, and the displacement error of the correction
against the truth (relative to none).

Usage::

    python benchmarks/edges.py [--size 320x180] [--scenes astronaut,rocket] [--near 1.3]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from skimage import data

from unjello.metrics import displacement_error
from unjello.pipeline import correct_frames
from unjello.simulate import Motion, pole_layers, simulate
from unjello.timing import SensorTiming
from unjello.warp import frame_maps

#: (share of the width a frame, readout)
SPEEDS = ((0.1, 0.4), (0.15, 1.0), (0.25, 0.4), (0.25, 1.0), (0.4, 0.7))
MARGIN = 8


def _psnr(a: np.ndarray, b: np.ndarray, mask: np.ndarray) -> float:
    if not mask.any():
        return float("nan")
    err = (a.astype(np.float64) - b.astype(np.float64))[mask]
    return float(10 * np.log10(255.0 ** 2 / max(float(np.mean(err ** 2)), 1e-10)))


def strip_masks(sim: list, timing: SensorTiming) -> list[tuple[np.ndarray, ...]]:
    """Per frame: the strip the previous frame saw, the next saw, none saw; the interior.

    The strip is where the true backward map leaves the frame; a pixel of it in a row
    read after the reference was seen by the previous frame, one read before it by the
    next (with the frame there: a pair's first frame has no previous one, its second no
    next). Bool masks.
    """
    out = []
    n = len(sim)
    for i, s in enumerate(sim):
        h, w = s.rolling.shape[:2]
        (mx, my), _ = frame_maps(s.motion, h, w)
        strip = (mx < -0.5) | (mx > w - 0.5) | (my < -0.5) | (my > h - 0.5)
        after = timing.row_times(h, 0.0) > timing.reference_time(h, 0.0)
        after = np.broadcast_to(after[:, None], (h, w))
        prev = strip & after & (i > 0)
        nxt = strip & ~after & (i < n - 1)
        inner = np.zeros((h, w), bool)
        inner[MARGIN:h - MARGIN, MARGIN:w - MARGIN] = True
        out.append((prev, nxt, strip & ~prev & ~nxt, inner & ~strip))
    return out


def run(scene_name: str, frac: float, readout: float, frames: int, size: tuple[int, int],
        near: float = 1.3) -> dict:
    """One case: simulate, correct by default, score."""
    w, h = size
    scene = getattr(data, scene_name)()
    timing = SensorTiming(readout)
    motion = Motion("pan", speed=frac * w)
    layers = []
    if near > 1.0:
        d = motion(np.linspace(-1.0, frames + 1.0, 64))[:, 0]
        layers = pole_layers(motion, size, (float(d.min()), float(d.max())), near)
    sim = list(simulate(scene, motion, timing, frames, size=size, layers=layers))
    rolling = [s.rolling for s in sim]
    t0 = time.process_time()
    out, traj = correct_frames(rolling, timing)
    cpu = (time.process_time() - t0) / frames
    masks = strip_masks(sim, timing)
    frame = np.zeros((h, w), bool)
    frame[MARGIN:h - MARGIN, MARGIN:w - MARGIN] = True
    row: dict = {"cpu_s": cpu}
    for tag, images in (("in", rolling), ("out", out)):
        for k, name in enumerate(("prev", "next", "unseen", "interior")):
            sel = [(o, s.truth, m[k]) for o, s, m in zip(images, sim, masks, strict=True)]
            allpix = np.concatenate([(o.astype(np.float64) - t)[m].ravel() for o, t, m in sel])
            row[f"{tag}_{name}"] = (float("nan") if not allpix.size else float(
                10 * np.log10(255.0 ** 2 / max(float(np.mean(allpix ** 2)), 1e-10))))
        row[f"{tag}_frame"] = float(np.mean([_psnr(o, s.truth, frame)
                                             for o, s in zip(images, sim, strict=True)]))
    row["strip_share"] = float(np.mean([(m[0] | m[1] | m[2]).mean() for m in masks]))
    row["ratio"] = (np.mean([displacement_error(f, s.motion) for f, s in
                             zip(traj.frames, sim, strict=True)])
                    / np.mean([displacement_error(None, s.motion) for s in sim]))
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="320x180")
    ap.add_argument("--scenes", default="astronaut,rocket")
    ap.add_argument("--near", type=float, default=1.3,
                    help="the poles' nearness (they move this times the background; 1: none)")
    args = ap.parse_args()
    size = tuple(int(v) for v in args.size.split("x"))
    print(f"{size[0]}x{size[1]}, flat poles in front ({args.near}x parallax); PSNR (dB) input -> "
          "default; the strip seen by the previous frame, by the next, by none")
    print(f"{'scene':10} {'kind':5} {'speed':>5} {'rho':>4} {'strip%':>6} "
          f"{'strip: prev':>15} {'next':>15} {'none':>15} {'interior':>15} {'frame':>15} "
          f"{'err':>6} {'cpu s/f':>7}")
    for scene in args.scenes.split(","):
        for frac, readout in SPEEDS:
            for kind, frames in (("clip", 10), ("pair", 2)):
                r = run(scene, frac, readout, frames, size,  # type: ignore[arg-type]
                        args.near)

                def pair(name: str, r: dict = r) -> str:
                    return f"{r['in_' + name]:6.2f} -> {r['out_' + name]:5.2f}"

                print(f"{scene:10} {kind:5} {frac:5.2f} {readout:4.1f} "
                      f"{100 * r['strip_share']:6.1f} {pair('prev'):>15} {pair('next'):>15} "
                      f"{pair('unseen'):>15} {pair('interior'):>15} {pair('frame'):>15} "
                      f"{r['ratio']:6.3f} "
                      f"{r['cpu_s']:7.2f}", flush=True)


if __name__ == "__main__":
    main()
