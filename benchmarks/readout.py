"""Readout time: the flicker measurement and the estimate from footage, against truth.

1. The LED frame in ``../shared/data/readout`` (1 kHz, published readout 15.730 ms).
2. ``estimate_readout`` (what ``--readout auto`` runs) on simulated clips with known
   readout: hand shake, pan-then-stop, pans that start from still (over one frame, or
   abruptly), drone jello, a diagonal pan that stops and a constant one at rho
   0.3 ... 1.0; true vs estimated, confidence, and the median / worst error per
   motion. "unsure" marks an estimate that fell back to 1.0 for lack of evidence.
3. Straight lines (:mod:`unjello.readout.lines`): a simulated street of buildings and
   poles (``street_scene``, its verticals upright, or leaning by 0.03 with the camera
   rolled by 0.05 rad), a constant pan, a two-frame pair and hand shake at rho
   0.3 ... 1.0 in all four scan directions: what ``estimate_readout`` says (with both
   cues), and whether it is confident and right, confident and wrong, or unknown.
4. What it picks on the shared real and rendered sequences: the model, the lens it fitted
   and the share of the motion the rotation explains (the phone clip's publisher states
   a rolling-shutter span of 33.312 ms at 30 fps, i.e. rho 1.0; TUM RS-VI sequence 4's
   authors a line delay that makes 0.60).
5. The research pairs (Fastec, Carla; readout 1.0): each two-frame pair, and each set
   pooled (``pool_estimates``).
6. A camera turning about three axes at hand-held rates through a pinhole and through
   a fisheye (``--rotation`` alone): the rotation model's estimate and the lens it fits.

Usage::

    python benchmarks/readout.py [--frames 12] [--size 320x240] [--skip-motion] [--rotation]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from skimage import data

from unjello.io.frames import read_image
from unjello.readout.flicker import readout_from_flicker
from unjello.readout.footage import estimate_readout, estimate_readout_file, pool_estimates
from unjello.readout.rotation import describe_lens
from unjello.simulate import Motion, simulate, street_scene
from unjello.timing import SensorTiming

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
RHOS = (0.3, 0.5, 0.7, 0.9, 1.0)


def motions(frames: int) -> dict[str, Motion]:
    return {"hand shake": Motion("shake"),
            "pan then stop": Motion("stop", speed=7.0, stop_at=frames / 2),
            "pan from rest": Motion.from_rest(8.0, 0.0),
            "diagonal from rest, abrupt": Motion.steps([(0.0, 0.0), (8.0, 4.0)], [2.3]),
            "drone jello": Motion("jello"),
            "diagonal pan then stop": _diagonal_stop(frames),
            "diagonal pan (constant)": Motion("diagonal", speed=6.1)}


def _diagonal_stop(frames: int) -> Motion:
    """Diagonal pan (6.1 px/frame in x, 0.6 of it in y) stopping at half the clip."""
    t = np.arange(0.0, frames + 2, 0.05)
    x = 6.1 * np.minimum(t, frames / 2)
    return Motion("spline", knots=(t, x, 0.6 * x))


def lines(frames: int, size: tuple[int, int]) -> None:
    """Print the straight-lines rows: street scenes, three motions, four directions."""
    print(f"\nstraight lines: a street scene, {size[0]}x{size[1]}; cells: both cues | the "
          "lines alone (+-sigma), '?' unknown; per row (both cues): confident and within "
          "0.05 / confident / all")
    directions = ("top-bottom", "bottom-top", "left-right", "right-left")
    cases = {"constant pan": (Motion("pan", speed=8.0), frames),
             "two-frame pair": (Motion("pan", speed=8.0), 2),
             "hand shake": (Motion("shake"), frames)}
    good = confident = total = lines_good = lines_conf = 0
    for lean, roll in ((0.0, 0.0), (0.03, 0.05)):
        scene = street_scene((3 * size[0], 3 * size[1]), lean=lean, roll=roll)
        print(f" scene lean {lean}, roll {roll} rad")
        for name, (motion, n) in cases.items():
            for d in directions:
                cells, row_good, row_conf = [], 0, 0
                for rho in RHOS:
                    sim = [s.rolling for s in simulate(scene, motion, SensorTiming(rho, d), n,
                                                       size=size)]
                    est = estimate_readout(sim, direction=d, max_frames=n)
                    alone = estimate_readout(sim, direction=d, max_frames=n, motion=False)
                    ok = est.reliable and abs(est.readout - rho) <= 0.05
                    row_good += ok
                    row_conf += est.reliable
                    lines_good += alone.reliable and abs(alone.readout - rho) <= 0.05
                    lines_conf += alone.reliable
                    cells.append((f"{est.readout:.3f}" if est.reliable else "?") + " | "
                                 + (f"{alone.readout:.3f}+-{alone.uncertainty:.3f}"
                                    if alone.reliable else "?"))
                good, confident, total = good + row_good, confident + row_conf, total + len(RHOS)
                print(f"  {name:15} {d:11}" + "".join(f"{c:>22}" for c in cells)
                      + f"   {row_good}/{row_conf}/{len(RHOS)}", flush=True)
    print(f"in all, both cues: {good} confident and within 0.05, "
          f"{confident - good} confident and wrong, {total - confident} unknown, of {total}")
    print(f"the lines alone: {lines_good} confident and within 0.05, "
          f"{lines_conf - lines_good} confident and wrong, {total - lines_conf} unknown")


def pairs() -> None:
    """Each research pair (two frames) and each set pooled; their readout is 1.0."""
    print("\nresearch pairs (two frames each, readout 1.0):")
    for name in ("fastec", "carla"):
        folder = SHARED / "pairs" / name
        if not folder.exists():
            print(f"  {name}: skipped, {folder} is absent")
            continue
        ests = []
        for pair in sorted(folder.iterdir()):
            est = estimate_readout([read_image(pair / "rs_0.png"), read_image(pair / "rs_1.png")])
            ests.append(est)
        known = [e for e in ests if e.reliable]
        worst = max((abs(e.readout - 1.0) for e in known), default=0.0)
        guesses = ", ".join(f"{e.best_guess:.2f}+-{e.uncertainty:.2f}" for e in ests
                            if np.isfinite(e.uncertainty))
        print(f"  {name}: {len(known)} of {len(ests)} pairs known (worst error {worst:.3f}); "
              f"best guesses {guesses}")
        pooled = pool_estimates(ests)
        print(f"  {name} pooled: {pooled.describe()} (best guess {pooled.best_guess:.3f})")


#: A hand-held camera's rates (rad/s) about x, y and z: three sinusoids each, 0.8-4 Hz,
#: the roll at 0.4 of the others (issue 78's real clips turn about all three axes).
def hand_rates(seed: int, amp: float = 1.2):
    """Return ``rate(t)`` -> (..., 3) rad/s for :func:`unjello.simulate.simulate_rotation`."""
    rng = np.random.default_rng(seed)
    f, ph = rng.uniform(0.8, 4.0, (3, 3)), rng.uniform(0, 2 * np.pi, (3, 3))
    a = rng.uniform(0.5, 1.0, (3, 3)) * amp

    def rate(t: np.ndarray) -> np.ndarray:
        t = np.asarray(t)[..., None, None]
        return (a * np.sin(2 * np.pi * f * t + ph)).sum(-1) * np.array([1.0, 1.0, 0.4])
    return rate


def rotating(frames: int = 16) -> None:
    """Print the estimate on a camera turning about three axes, through two lenses."""
    from unjello.io.roundtrip import degrade
    from unjello.simulate import simulate_rotation

    scene = data.astronaut()
    scene = np.concatenate([np.concatenate([scene, scene[:, ::-1]], 1),
                            np.concatenate([scene[::-1], scene[::-1, ::-1]], 1)], 0)
    lenses = {"pinhole, f 300 px": (300.0, None, False),
              "wide (fisheye), f 240 px, k1 -0.02": (240.0, (-0.02, 0.01, -0.005, 0.001), False),
              "the same, noise 3 and CRF 26": (240.0, (-0.02, 0.01, -0.005, 0.001), True)}
    print(f"\na camera turning about three axes (hand-held rates, {frames} frames of 480x384): "
          "true -> estimated +-uncertainty ('?' unknown), the lens fitted")
    errors = []
    for name, (focal, distortion, degraded) in lenses.items():
        print(f"  {name}:")
        for rho in (0.3, 0.6, 1.0):
            cells = []
            for seed in (1, 2):
                sim, _ = simulate_rotation(scene, hand_rates(seed), SensorTiming(rho), frames,
                                           size=(480, 384), focal=focal, distortion=distortion)
                clip = [f.rolling for f in sim]
                if degraded:
                    clip = degrade(clip, seed=seed, noise=3.0, crf=26)
                est = estimate_readout(clip, max_frames=frames)
                state = "" if est.reliable else "?"
                lens = describe_lens(est.lens) if est.lens is not None else est.model
                cells.append(f"{est.readout:.3f}{state} +-{est.uncertainty:.3f} ({lens})")
                errors.append(abs(est.readout - rho) if est.reliable else np.inf)
            print(f"    {rho:.1f} -> " + "; ".join(cells), flush=True)
    print(f"  worst error {max(errors):.3f}, {sum(np.isfinite(errors))} of {len(errors)} known")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=12)
    ap.add_argument("--size", default="320x240")
    ap.add_argument("--skip-motion", action="store_true",
                    help="only the straight lines and the research pairs")
    ap.add_argument("--rotation", action="store_true",
                    help="only the camera turning about three axes through a lens")
    args = ap.parse_args()
    size = tuple(int(v) for v in args.size.split("x"))
    if args.rotation:
        rotating()
        return
    if args.skip_motion:
        lines(args.frames, size)
        pairs()
        return
    led = SHARED / "readout" / "led_1khz_nikon1j1_1080p30.png"
    if led.exists():
        r = readout_from_flicker(read_image(led), 1000.0)
        print(f"LED frame, 1 kHz: {r.milliseconds:.3f} ms (published 15.730 ms, "
              f"{100 * (r.milliseconds / 15.730 - 1):+.2f} %)")
    else:
        print(f"skipped the LED frame: {led} is absent")
    print(f"\nestimate from footage: {args.frames} simulated frames of {size[0]}x{size[1]}; "
          "true -> estimated (confidence)")
    print(f"{'motion':27}" + "".join(f"{rho:>21}" for rho in RHOS) + "   median |err|  worst")
    all_err = []
    for name, motion in motions(args.frames).items():
        cells, errs = [], []
        for rho in RHOS:
            sim = [s.rolling for s in simulate(data.astronaut(), motion, SensorTiming(rho),
                                               args.frames, size=size)]
            est = estimate_readout(sim, max_frames=args.frames)
            tag = "" if est.reliable else " unsure"
            cells.append(f"{est.readout:.3f} ({est.confidence:.2f}){tag}")
            errs.append(abs(est.readout - rho))
        all_err += errs
        print(f"{name:27}" + "".join(f"{c:>21}" for c in cells)
              + f"   {np.median(errs):12.3f}  {max(errs):5.3f}", flush=True)
    print(f"all motions: median |err| {np.median(all_err):.3f}, worst {max(all_err):.3f}")
    varying = all_err[:-len(RHOS)]  # the constant pan is last: no method can tell
    print(f"all but the constant pan: median |err| {np.median(varying):.3f}, "
          f"worst {max(varying):.3f}")
    print("\nshared sequences (readout about one frame interval, TUM's 0.60):")
    fastec, carla = SHARED / "pairs" / "fastec", SHARED / "pairs" / "carla"
    seqs: dict[str, Path | list[Path]] = {
        # pair_12's second frame is pair_09's first: three consecutive frames.
        "fastec pair_12 + pair_09 (3 frames)": [fastec / "pair_12" / "rs_0.png",
                                                fastec / "pair_12" / "rs_1.png",
                                                fastec / "pair_09" / "rs_1.png"],
        "carla pair_01 (2 frames)": [carla / "pair_01" / "rs_0.png",
                                     carla / "pair_01" / "rs_1.png"],
        "carla_town05_rs (10 frames)": SHARED / "sequences" / "carla_town05_rs",
        "spinners_rs (6 frames, still camera)": SHARED / "sequences" / "spinners_rs",
        "phone_gyro (first 60 of 103 frames)": SHARED / "sequences" / "phone_gyro"
                                                / "reshape",
        "tum_rsvi_seq4 (50 frames, truth 0.60)": SHARED / "sequences" / "tum_rsvi_seq4"}
    for name, path in seqs.items():
        first = path[0] if isinstance(path, list) else path
        if not first.exists():
            print(f"  {name}: skipped, {first} is absent")
            continue
        if isinstance(path, list):
            est = estimate_readout([read_image(p) for p in path])
        else:
            est = estimate_readout_file(path, max_frames=60)
        state = "estimated" if est.reliable else "unsure, fell back to"
        guess = (f", best guess {est.best_guess:.2f} +-{est.uncertainty:.2f}"
                 if not est.reliable and np.isfinite(est.uncertainty) else "")
        model = est.model + (f" through {describe_lens(est.lens)}, explaining "
                             f"{100 * est.explained:.1f}% of the motion"
                             if est.lens is not None else "")
        print(f"  {name}: {state} {est.readout:.3f} (confidence {est.confidence:.2f}, "
              f"{est.cue}, {model}{guess})", flush=True)
    lines(args.frames, size)
    pairs()
    rotating()


if __name__ == "__main__":
    main()
