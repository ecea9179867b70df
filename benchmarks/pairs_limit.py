"""What limits the dense method on the research pairs: motion two frames cannot show.

A pair gives two frames. Frame 1's top rows are imaged at ``T`` and corrected to the middle
scanline's time ``1.5 T``: half a frame *beyond* the interval ``[0, T]`` over which their
flow to frame 0 measured the motion. Any change of the camera's velocity between the two
intervals (acceleration) is invisible in two frames -- it is confounded with velocity
that varies with the row (perspective), which the method's prior prefers -- and lands in
the top band as error.

For every pair with all four global-shutter images (times 0, T/2, T, 1.5 T), this script
measures from that truth, which the method never sees, how the top band's content
velocity over ``[T, 1.5 T]`` differs from its mean over ``[0, T]``, and compares it with
the error of the method's backward map in the same band (against the map the
global-shutter frame ``gs_1_m`` gives: DIS flow from it to ``rs_1``, on textured pixels it
explains). If the top band's error is the unseen acceleration, the two agree in sign.

With ``--oracle`` it also scores the method's own backward map with that change taken
out of the upper half (measured per eighth of the height from the truth, applied in
proportion to how far each row is extrapolated): what knowing the acceleration would be
worth, an upper bound no two-frame method can reach.

Usage::

    python benchmarks/pairs_limit.py [--sets fastec,carla] [--band 8] [--oracle]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np

from unjello.io.frames import read_image
from unjello.metrics import psnr
from unjello.motion.flow.dis import optical_flow
from unjello.pipeline import correct_frames
from unjello.timing import pixel_grid
from unjello.warp.maps import field_maps, resize_maps

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "pairs"
NAMES = ("gs_0_f", "gs_0_m", "gs_1_f", "gs_1_m", "rs_0", "rs_1")


def grey(image: np.ndarray) -> np.ndarray:
    return cv2.cvtColor(image, cv2.COLOR_RGB2GRAY).astype(np.float32)


def flow(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Full-resolution DIS flow with ``a(p) ~ b(p + F(p))``."""
    return optical_flow(grey(a), grey(b), "medium", max_width=0, finest_scale=0)


def textured(image: np.ndarray) -> np.ndarray:
    """Pixels with enough gradient around them for a flow to be measured."""
    g = grey(image)
    return cv2.blur(np.hypot(cv2.Sobel(g, cv2.CV_32F, 1, 0),
                             cv2.Sobel(g, cv2.CV_32F, 0, 1)), (7, 7)) > 40


def unseen_change(flows: list[tuple[np.ndarray, np.ndarray]], band: slice) -> np.ndarray:
    """Content velocity over [T, 1.5T] minus its mean over [0, T], px per half frame.

    ``flows`` holds, for the half frames [0, T/2], [T/2, T], [T, 1.5T], the flow from the
    later global-shutter image to the earlier one and the later image's textured pixels.
    """
    v = [np.median(-f[band][m[band]], axis=0) if m[band].any() else np.full(2, np.nan)
         for f, m in flows]
    return v[2] - 0.5 * (v[0] + v[1])


def map_error(out: np.ndarray, maps: tuple[np.ndarray, np.ndarray], rs: list[np.ndarray],
              truth: np.ndarray, band: slice) -> tuple[np.ndarray, float, float]:
    """Median error (x, y) of the method's backward map in ``band``; band and whole PSNR."""
    h, w = truth.shape[:2]
    mx, my = maps
    gx, gy = pixel_grid(h, w)
    f = flow(truth, rs[1])  # the truth's map: output p takes rs_1 at p + f(p)
    seen = cv2.remap(grey(rs[1]), gx + f[..., 0], gy + f[..., 1], cv2.INTER_LINEAR)
    good = (cv2.blur(np.abs(seen - grey(truth)), (7, 7)) < 4) & textured(truth)
    m = good[band]
    err = np.full(2, np.nan)
    if m.sum() > 100:
        err = np.array([np.median((mx - gx - f[..., 0])[band][m]),
                        np.median((my - gy - f[..., 1])[band][m])])
    return err, psnr(out[band], truth[band]), psnr(out, truth)


def without_change(rs1: np.ndarray, maps: tuple[np.ndarray, np.ndarray],
                   flows: list[tuple[np.ndarray, np.ndarray]], bands: int = 4) -> np.ndarray:
    """``rs1`` through the method's maps with the unseen change taken out of the upper half."""
    h = rs1.shape[0]
    ref = (h - 1) / 2
    edges = np.linspace(0, h // 2, bands + 1).astype(int)
    centres = 0.5 * (edges[:-1] + edges[1:])
    change = np.nan_to_num(np.array([unseen_change(flows, slice(a, b))
                                     for a, b in zip(edges[:-1], edges[1:], strict=True)]))
    y = np.arange(h, dtype=np.float64)
    reach = np.clip((ref - y) / ref, 0, None)  # share of a half frame the row is carried
    shift = [(np.interp(y, centres, change[:, k]) * reach)[:, None].astype(np.float32)
             for k in range(2)]
    return cv2.remap(rs1, maps[0] - shift[0], maps[1] - shift[1], cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_REPLICATE)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", default="fastec,carla")
    ap.add_argument("--band", type=int, default=8, help="top band = first 1/BAND of the rows")
    ap.add_argument("--oracle", action="store_true",
                    help="also score the maps with the unseen change taken out")
    args = ap.parse_args()
    if not SHARED.is_dir():
        raise SystemExit(f"skipped: {SHARED} is absent (the shared data lives beside the repo)")
    for name in args.sets.split(","):
        change, error, scores = [], [], []
        for pair in sorted((SHARED / name).iterdir()):
            if not all((pair / f"{n}.png").exists() for n in NAMES):
                continue
            *gs, rs0, rs1 = (read_image(pair / f"{n}.png")[..., :3] for n in NAMES)
            h, w = rs1.shape[:2]
            band = slice(0, h // args.band)
            flows = [(flow(gs[b], gs[a]), textured(gs[b])) for a, b in ((0, 1), (1, 2), (2, 3))]
            change.append(unseen_change(flows, band))
            out, traj = correct_frames([rs0, rs1])
            maps = resize_maps(*field_maps(traj.frames[1].field, frame=(h, w)), h, w)
            err, top_db, whole_db = map_error(out[1], maps, [rs0, rs1], gs[3], band)
            error.append(err)
            scores.append((top_db, whole_db))
            line = (f"  {name}/{pair.name}: unseen velocity change x {change[-1][0]:+6.2f} "
                    f"y {change[-1][1]:+6.2f} px | top-band map error x {err[0]:+6.2f} "
                    f"y {err[1]:+6.2f} px | top band {top_db:5.2f} dB, whole {whole_db:5.2f} dB")
            if args.oracle:
                own = cv2.remap(rs1, *maps, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
                known = without_change(rs1, maps, flows)
                scores[-1] += (psnr(own, gs[3]), psnr(known, gs[3]))
                line += f" | maps {scores[-1][2]:5.2f} -> {scores[-1][3]:5.2f} dB"
            print(line, flush=True)
        c, e = np.array(change), np.array(error)
        ok = np.isfinite(e).all(axis=1) & np.isfinite(c).all(axis=1)
        mean = np.mean(scores, axis=0)
        print(f"{name}: {len(scores)} pairs; top 1/{args.band} {mean[0]:.2f} dB, "
              f"whole {mean[1]:.2f} dB")
        if args.oracle:
            print(f"  the method's maps alone {mean[2]:.2f} dB; with the unseen change "
                  f"taken out of the upper half {mean[3]:.2f} dB")
        for k, axis in enumerate("xy"):
            # Content moving d px further than measured leaves the map d px short: error = +d.
            agree = int(np.sum(np.sign(c[ok, k]) == np.sign(e[ok, k])))
            corr = float(np.corrcoef(c[ok, k], e[ok, k])[0, 1])
            print(f"  {axis}: sign of the error = sign of the unseen change in {agree} of "
                  f"{ok.sum()}; correlation {corr:+.2f}; mean |change| "
                  f"{np.abs(c[ok, k]).mean():.2f} px, "
                  f"mean |error| {np.abs(e[ok, k]).mean():.2f} px")


if __name__ == "__main__":
    main()
