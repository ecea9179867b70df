"""The frame's edge in fast motion (issue 38): PSNR of the strip, the interior, the frame.

During a fast pan the reference instant shows, at the side the camera turns towards or
away from, content that the frame's own scanlines never saw: the output pixels whose
true source lies outside the frame (the *strip*). A neighbouring frame saw most of it.
This renders simulated clips (10 frames) and pairs (2 frames) at 10-40 % of the width a
frame (``--speeds``: others, e.g. ``0.6:0.4,0.6:1.0,0.5:0.7``), readouts 0.4-1.0, with
straight flat poles passing in front 1.3 times as near as the background (parallax;
``--near``: 1 for none, 1.0001 for poles as far as the background, a flagpole against the
sky; two poles' motions a frame apart at least, as one fence post could not be told from
the next), and prints, per case, the PSNR (dB) against the global-shutter truth of:

- the strip (pixels whose true source lies outside the frame), split into the pixels
  the previous frame saw (rows read after the reference), those the next saw (rows read
  before it) and those none saw (a pair's or a clip's first frame's late rows, its last
  frame's early ones);
- the interior (every other pixel, 8 px from the frame's border);
- the whole frame (8 px margin);

for the input and the default correction; the displacement error of the correction
against the truth (relative to none); the median bend of the upright poles within 30 px
of a side, in the input and the output (:func:`pole_bends`; px; a pole torn apart counts
as its width plus 20 px), how many of them are straight within 1 px, and the share of
their rows within 1 px -- in the output, also split between the poles a neighbouring
frame shows too (``2 fr``: their motion can be measured) and those only their own frame
shows (``1 fr``: entering or leaving between two frames; no flow measures their motion,
and they keep the motion around them: straightening them would take a prior that they
stand upright); the share of pixels none saw, true / as the run reports it
(``unseen``, ``correct --json``); the frames whose correction still folds or tears
more than ``FOLD_WARNING`` of the picture (the run's warning); and the worst frame's PSNR.

The fitted objects' decisions are thresholds: a case's frame can flip by several dB for a
change of a hundredth of a pixel upstream. ``--seeds N`` corrects each case N times, the
input as rendered and N - 1 times with a little noise (0.7 grey levels, rounded), and
adds the frame PSNR's mean over them and the worst frame of all: compare changes there.

``--direction diagonal`` pans down as well, 0.6 times as fast as across; ``y`` only down
(a tilt: the rows entering at the top were seen by no earlier frame), the speed still a
share of the width.

Usage::

    python benchmarks/edges.py [--size 320x180] [--scenes astronaut,rocket] [--near 1.3]
                               [--direction x|diagonal|y] [--seeds 1]
                               [--speeds 0.1:0.4,0.15:1.0,0.25:0.4,0.25:1.0,0.4:0.7]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from skimage import data

from unjello.metrics import displacement_error
from unjello.motion.dense.method import FOLD_WARNING
from unjello.pipeline import correct_frames
from unjello.simulate import Motion, pole_layers, simulate
from unjello.timing import SensorTiming
from unjello.warp.warper import frame_maps

#: (share of the width a frame, readout)
SPEEDS = ((0.1, 0.4), (0.15, 1.0), (0.25, 0.4), (0.25, 1.0), (0.4, 0.7))
MARGIN = 8
#: Poles within this many pixels of a side have their bend reported.
SIDE = 30


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


def pole_bends(image: np.ndarray, truth: np.ndarray, colours: list[np.ndarray],
               side: int = SIDE) -> list[tuple[float, float, float]]:
    """How far each upright pole within ``side`` px of a side strays in ``image`` (px).

    A pole is found in the global-shutter ``truth`` as the columns whose every row shows
    its flat colour (within 12 levels); in ``image``, per row, the mean column of that
    colour within the pole's width plus 20 px either side of it. Only rows where the
    truth shows that colour nowhere else in that window are scored (a dark pole before a
    dark background is not). A row where the colour is not found at all counts as the
    pole's width plus 20 px (torn).

    Returns
    -------
    list of (float, float, float)
        Per pole: the largest distance of a scored row's mean from the truth's, the share
        of its scored rows within 1 px, and its centre column in ``truth``.
    """
    h, w = truth.shape[:2]
    out = []
    for colour in colours:
        hit = np.abs(truth.astype(np.int16) - colour).max(axis=-1) <= 12
        cols = np.flatnonzero(hit.mean(axis=0) >= 0.98)
        if not cols.size or cols[-1] - cols[0] > 40:
            continue  # not in the frame, or two poles of one colour: not scored
        centre = cols.mean()
        if min(cols[0], w - 1 - cols[-1]) > side or cols[0] == 0 or cols[-1] == w - 1:
            continue  # not near a side, or cut by the frame's edge
        reach = int(cols[-1] - cols[0]) // 2 + 20
        lo, hi = max(0, int(centre) - reach), min(w, int(centre) + reach + 1)
        own = np.zeros(hi - lo, bool)
        own[cols[0] - lo:cols[-1] - lo + 1] = True
        clean = ~hit[:, lo:hi][:, ~own].any(axis=1)
        clean[:MARGIN] = clean[h - MARGIN:] = False
        if clean.sum() < h // 2:
            continue  # its colour is all around it
        found = np.abs(image[:, lo:hi].astype(np.int16) - colour).max(axis=-1) <= 12
        x = np.arange(lo, hi, dtype=np.float64)
        count = found.sum(axis=1)
        rows = np.abs(np.where(count > 0, (found * x).sum(axis=1) / np.maximum(count, 1)
                               - centre, reach))[clean]
        out.append((float(rows.max()), float(np.mean(rows <= 1.0)), float(centre)))
    return out


def shown_by_neighbour(sim: list, layers: list, timing: SensorTiming, i: int,
                       colour: np.ndarray, centre: float) -> bool:
    """Whether frame ``i - 1`` or ``i + 1`` shows the pole at ``centre`` in frame i's truth.

    The pole is the layer of that colour the truth shows nearest ``centre``; a neighbour
    shows it where its rolling-shutter frame's layer map has it in a tenth of the rows.
    A pole no neighbour shows is one whose motion no flow can measure.
    """
    h = sim[i].rolling.shape[0]
    t_ref = np.array([timing.reference_time(h, float(i))])
    best, near = None, 3.0
    for k, layer in enumerate(layers):
        if np.abs(layer.image[0, 0] - colour).max() > 0:
            continue
        at = layer.position[0] + layer.motion(t_ref)[0, 0] + (layer.image.shape[1] - 1) / 2
        if abs(at - centre) <= near:
            best, near = k, abs(at - centre)
    if best is None:
        return False
    return any((sim[j].layer == best + 1).any(axis=1).sum() >= h // 10
               for j in (i - 1, i + 1) if 0 <= j < len(sim))


#: Pan directions (``--direction``): the motion of a pan of ``speed`` px a frame.
DIRECTIONS = {
    "x": lambda speed: Motion("pan", speed=speed),
    "diagonal": lambda speed: Motion.steps([(speed, 0.6 * speed)], [100.0]),
    "y": lambda speed: Motion.steps([(0.0, speed)], [100.0]),
}


#: Standard deviation (grey levels) of the noise added for each seed after the first.
SEED_NOISE = 0.7


def run(scene_name: str, frac: float, readout: float, frames: int, size: tuple[int, int],
        near: float = 1.3, direction: str = "x", seeds: int = 1) -> dict:
    """One case: simulate, correct by default, score (``seeds``: see the module's notes)."""
    w, h = size
    scene = getattr(data, scene_name)()
    timing = SensorTiming(readout)
    motion = DIRECTIONS[direction](frac * w)
    layers = []
    if near > 1.0:
        d = motion(np.linspace(-1.0, frames + 1.0, 64))[:, 0]
        # Two pole's motions a frame apart at least: a flat pole the next one replaces
        # between frames cannot be told from it (temporal aliasing, as a fence's).
        apart = max(120.0, 2 * near * frac * 640)
        layers = pole_layers(motion, size, (float(d.min()), float(d.max())), near,
                             gap=(apart, apart + 140.0))
    sim = list(simulate(scene, motion, timing, frames, size=size, layers=layers))
    rolling = [s.rolling for s in sim]
    t0 = time.process_time()
    out, traj = correct_frames(rolling, timing)
    cpu = (time.process_time() - t0) / frames
    masks = strip_masks(sim, timing)
    frame = np.zeros((h, w), bool)
    frame[MARGIN:h - MARGIN, MARGIN:w - MARGIN] = True
    row: dict = {"cpu_s": cpu}
    per_seed = [[_psnr(o, s.truth, frame) for o, s in zip(out, sim, strict=True)]]
    for seed in range(1, seeds):
        rng = np.random.default_rng(seed)
        noisy = [np.clip(np.round(r + rng.normal(0.0, SEED_NOISE, r.shape)), 0, 255
                         ).astype(r.dtype) for r in rolling]
        again, _ = correct_frames(noisy, timing)
        per_seed.append([_psnr(o, s.truth, frame) for o, s in zip(again, sim, strict=True)])
    row["seeds_frame"] = float(np.mean(per_seed))
    row["worst"] = float(np.min(per_seed))
    for tag, images in (("in", rolling), ("out", out)):
        for k, name in enumerate(("prev", "next", "unseen", "interior")):
            sel = [(o, s.truth, m[k]) for o, s, m in zip(images, sim, masks, strict=True)]
            allpix = np.concatenate([(o.astype(np.float64) - t)[m].ravel() for o, t, m in sel])
            row[f"{tag}_{name}"] = (float("nan") if not allpix.size else float(
                10 * np.log10(255.0 ** 2 / max(float(np.mean(allpix ** 2)), 1e-10))))
        row[f"{tag}_frame"] = float(np.mean([_psnr(o, s.truth, frame)
                                             for o, s in zip(images, sim, strict=True)]))
    colours = [layer.image[0, 0] for layer in layers]
    for tag, images in (("in", rolling), ("out", out)):
        bends = []  # (bend, rows within 1 px, a neighbour shows the pole: the output's split)
        for i, (o, s) in enumerate(zip(images, sim, strict=True)):
            for c in colours:
                for b, r, centre in pole_bends(o, s.truth, [c]):
                    bends.append((b, r, tag == "out" and shown_by_neighbour(
                        sim, layers, timing, i, c, centre)))
        row[f"{tag}_bend"] = float(np.median([b for b, _, _ in bends])) if bends else float("nan")
        row[f"{tag}_rows"] = float(np.mean([r for _, r, _ in bends])) if bends else float("nan")
        row[f"{tag}_straight"] = (f"{sum(b <= 1.0 for b, _, _ in bends)}/{len(bends)}"
                                  if bends else "-")
    for name, seen in (("two", True), ("one", False)):
        rows = [r for _, r, shown in bends if shown == seen]  # the output's, from the loop
        row[f"out_rows_{name}"] = float(np.mean(rows)) if rows else float("nan")
    row["folded"] = f"{sum(f.folds > FOLD_WARNING for f in traj.frames)}/{len(traj.frames)}"
    row["unseen_true"] = float(np.mean([m[2].mean() for m in masks]))
    row["unseen_said"] = float(np.mean([f.unseen for f in traj.frames]))
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
                    help="the poles' nearness (they move this times the background; 1: none; "
                         "1.0001: as far as the background)")
    ap.add_argument("--seeds", type=int, default=1,
                    help="correct each case this many times, with a little noise after the "
                         "first; adds the frame's mean over them and the worst frame")
    ap.add_argument("--direction", choices=sorted(DIRECTIONS), default="x",
                    help="pan across (x), across and down (diagonal: 0.6 as fast down) or "
                         "down (y)")
    ap.add_argument("--speeds", default=",".join(f"{f}:{r}" for f, r in SPEEDS),
                    help="the cases: SHARE:READOUT,... (the pan's share of the width a "
                         "frame, the readout); e.g. 0.6:0.4,0.6:1.0,0.5:0.7 for the fastest "
                         "pans issue 38 names")
    args = ap.parse_args()
    size = tuple(int(v) for v in args.size.split("x"))
    speeds = [tuple(float(v) for v in case.split(":")) for case in args.speeds.split(",")]
    print(f"{size[0]}x{size[1]}, pan {args.direction}, flat poles in front ({args.near}x "
          "parallax); PSNR (dB) input -> default; the strip seen by the previous frame, by the "
          "next, by none")
    print(f"{'scene':10} {'kind':5} {'speed':>5} {'rho':>4} {'strip%':>6} "
          f"{'strip: prev':>15} {'next':>15} {'none':>15} {'interior':>15} {'frame':>15} "
          f"{'err':>6} {'pole bend px':>14} {'straight':>11} {'rows <= 1 px':>14} "
          f"{'2 fr / 1 fr':>11} "
          f"{'none%':>11} {'folded':>6} {'cpu s/f':>7} {'seeds':>6} {'worst':>6}")
    for scene in args.scenes.split(","):
        for frac, readout in speeds:
            for kind, frames in (("clip", 10), ("pair", 2)):
                r = run(scene, frac, readout, frames, size,  # type: ignore[arg-type]
                        args.near, args.direction, args.seeds)

                def pair(name: str, r: dict = r) -> str:
                    return f"{r['in_' + name]:6.2f} -> {r['out_' + name]:5.2f}".replace(
                        "nan", "-")

                split = f"{r['out_rows_two']:4.2f} / {r['out_rows_one']:4.2f}".replace(
                    "nan", "-")
                print(f"{scene:10} {kind:5} {frac:5.2f} {readout:4.1f} "
                      f"{100 * r['strip_share']:6.1f} {pair('prev'):>15} {pair('next'):>15} "
                      f"{pair('unseen'):>15} {pair('interior'):>15} {pair('frame'):>15} "
                      f"{r['ratio']:6.3f} {pair('bend'):>14} "
                      f"{r['in_straight'] + ' -> ' + r['out_straight']:>11} "
                      f"{pair('rows'):>14} "
                      f"{split:>11} "
                      f"{100 * r['unseen_true']:4.1f}/{100 * r['unseen_said']:4.1f}  "
                      f"{r['folded']:>6} "
                      f"{r['cpu_s']:7.2f} {r['seeds_frame']:6.2f} {r['worst']:6.2f}",
                      flush=True)


if __name__ == "__main__":
    main()
