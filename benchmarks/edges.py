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
import functools

from unjello.motion.dense.method import FOLD_WARNING
from unjello.pipeline import correct_frames
from unjello.simulate.poles import DIRECTIONS
from unjello.simulate.poles import run as run_case

#: A case corrected by default (:func:`unjello.simulate.poles.run`).
run = functools.partial(run_case, correct=correct_frames, fold_warning=FOLD_WARNING)

#: (share of the width a frame, readout)
SPEEDS = ((0.1, 0.4), (0.15, 1.0), (0.25, 0.4), (0.25, 1.0), (0.4, 0.7))
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
