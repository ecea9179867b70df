"""Flat poles passing close in front of a pan, and the strip beyond the frame's edge.

The scene of ``benchmarks/edges.py`` and the tests of what a frame does not see: a photo
panned fast (across, diagonally or down), with flat upright poles nearer than it
(:func:`~unjello.simulate.render.pole_layers`), rendered with its truth; and its scores:
the strip beyond the frame's edge that the previous or next frame saw, or none
(:func:`strip_masks`), how far each pole near a side strays from upright
(:func:`pole_bends`), and whether a neighbour shows it (:func:`shown_by_neighbour`).
:func:`run` corrects a case with the function a caller passes (the simulator does not
import the pipeline) and scores it.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
from skimage import data

from ..metrics import displacement_error, region_psnr
from ..timing import SensorTiming
from ..trajectory import Trajectory
from ..warp.maps import frame_maps
from .motion import Motion
from .render import pole_layers, simulate

__all__ = ["DIRECTIONS", "MARGIN", "SIDE", "SEED_NOISE", "strip_masks", "pole_bends",
           "shown_by_neighbour", "run"]

#: Pixels left out at each side of a frame's whole-frame PSNR.
MARGIN = 8
#: Poles within this many pixels of a side have their bend reported.
SIDE = 30


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
        near: float = 1.3, direction: str = "x", seeds: int = 1, *,
        correct: Callable[[list[np.ndarray], SensorTiming], tuple[list[np.ndarray], Trajectory]],
        fold_warning: float) -> dict:
    """One case: simulate, correct with ``correct``, score.

    ``seeds`` corrects the case that many times, the input as rendered and then with a
    little noise (:data:`SEED_NOISE`), for the mean and the worst of the frame PSNRs;
    ``fold_warning`` is the share of folds a frame is counted as folded over.
    """
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
    out, traj = correct(rolling, timing)
    cpu = (time.process_time() - t0) / frames
    masks = strip_masks(sim, timing)
    frame = np.zeros((h, w), bool)
    frame[MARGIN:h - MARGIN, MARGIN:w - MARGIN] = True
    row: dict = {"cpu_s": cpu}
    per_seed = [[region_psnr(o, s.truth, frame) for o, s in zip(out, sim, strict=True)]]
    for seed in range(1, seeds):
        rng = np.random.default_rng(seed)
        noisy = [np.clip(np.round(r + rng.normal(0.0, SEED_NOISE, r.shape)), 0, 255
                         ).astype(r.dtype) for r in rolling]
        again, _ = correct(noisy, timing)
        per_seed.append([region_psnr(o, s.truth, frame) for o, s in zip(again, sim, strict=True)])
    row["seeds_frame"] = float(np.mean(per_seed))
    row["worst"] = float(np.min(per_seed))
    for tag, images in (("in", rolling), ("out", out)):
        for k, name in enumerate(("prev", "next", "unseen", "interior")):
            sel = [(o, s.truth, m[k]) for o, s, m in zip(images, sim, masks, strict=True)]
            allpix = np.concatenate([(o.astype(np.float64) - t)[m].ravel() for o, t, m in sel])
            row[f"{tag}_{name}"] = (float("nan") if not allpix.size else float(
                10 * np.log10(255.0 ** 2 / max(float(np.mean(allpix ** 2)), 1e-10))))
        row[f"{tag}_frame"] = float(np.mean([region_psnr(o, s.truth, frame)
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
    folded = sum(f.diagnostics.folds > fold_warning for f in traj.frames)
    row["folded"] = f"{folded}/{len(traj.frames)}"
    row["unseen_true"] = float(np.mean([m[2].mean() for m in masks]))
    row["unseen_said"] = float(np.mean([f.diagnostics.unseen for f in traj.frames]))
    row["strip_share"] = float(np.mean([(m[0] | m[1] | m[2]).mean() for m in masks]))
    row["ratio"] = (np.mean([displacement_error(f, s.motion) for f, s in
                             zip(traj.frames, sim, strict=True)])
                    / np.mean([displacement_error(None, s.motion) for s in sim]))
    return row
