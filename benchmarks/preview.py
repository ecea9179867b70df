"""The preview's re-render time at 1080p: one frame corrected again after a control change.

A simulated 1080p clip (hand shake, readout 0.8, 12 frames) is held by
:class:`unjello.preview.PreviewClip`; frame 6 is corrected once at the starting
settings (the flows of its window are measured then), then again at other readouts,
another reference and the camera-only model, as the page asks when a control moves. Each
time includes what the API adds: the PNG the page receives.

Usage::

    python benchmarks/preview.py [--size 1920x1080]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from skimage import data

from unjello.io.frames import write_image
from unjello.preview import PreviewClip, PreviewSettings, encode_png
from unjello.simulate import Motion, simulate
from unjello.timing import SensorTiming


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="1920x1080")
    args = ap.parse_args()
    size = tuple(int(v) for v in args.size.split("x"))
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "clip"
        folder.mkdir()
        for i, s in enumerate(simulate(data.astronaut(), Motion("shake"), SensorTiming(0.8),
                                       12, size=size)):
            write_image(folder / f"f{i:03d}.png", s.rolling)
        with PreviewClip(folder) as clip:
            changes = [("first view, readout 1.0 (flows measured)", PreviewSettings()),
                       ("readout 0.8", PreviewSettings(readout=0.8)),
                       ("readout 0.6", PreviewSettings(readout=0.6)),
                       ("readout 0.8, reference first",
                        PreviewSettings(readout=0.8, reference="first")),
                       ("readout 0.8, camera only", PreviewSettings(readout=0.8,
                                                                    camera_only=True)),
                       ("readout 0.8 again", PreviewSettings(readout=0.8))]
            print(f"frame 6 of {size[0]}x{size[1]}: seconds to the PNG the page receives")
            for label, settings in changes:
                t0 = time.perf_counter()
                image, _ = clip.corrected(6, settings)
                encode_png(image)
                print(f"  {label:42} {time.perf_counter() - t0:6.3f}", flush=True)


if __name__ == "__main__":
    main()
