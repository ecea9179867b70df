"""The built-in example: a panned photo, rolled, corrected, shown side by side."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..exports.outputs import side_by_side
from ..io.frames import write_image
from ..io.sink import FrameSink, check_new
from ..metrics import displacement_error, psnr
from ..pipeline import correct_frames
from ..simulate import Motion, simulate
from ..timing import SensorTiming

__all__ = ["run_demo"]


def run_demo(output: str | os.PathLike = "unjello_demo.mp4", *, frames: int = 36,
             overwrite: bool = False, readout: float = 1.0, speed: float = 9.0) -> dict:
    """Simulate a fast pan over ``skimage.data.astronaut``, correct it, write before/after.

    Parameters
    ----------
    output : path-like
        Side-by-side video; a PNG of the middle frame is written with the same stem.
    frames : int
        Clip length.
    overwrite : bool
        Replace existing outputs.
    readout, speed : float
        Readout ratio and pan speed (px per frame) of the simulated camera.

    Returns
    -------
    dict
        Error and PSNR before and after, sizes and output paths.
    """
    from skimage import data

    output = Path(output)
    still = output.with_suffix(".png")
    check_new(still, overwrite)
    timing = SensorTiming(readout)
    sim = list(simulate(data.astronaut(), Motion("diagonal", speed=speed), timing, frames,
                        size=(448, 336)))
    corrected, traj = correct_frames([s.rolling for s in sim], timing)
    err_before = float(np.mean([displacement_error(None, s.motion) for s in sim]))
    err_after = float(np.mean([displacement_error(f, s.motion)
                               for f, s in zip(traj.frames, sim, strict=True)]))
    margin = int(np.ceil(np.abs(traj.displacements()).max())) + 1
    psnr_before = float(np.mean([psnr(s.rolling, s.truth, margin) for s in sim]))
    psnr_after = float(np.mean([psnr(c, s.truth, margin)
                                for c, s in zip(corrected, sim, strict=True)]))
    with FrameSink(output, 30.0, overwrite) as sink:
        for s, c in zip(sim, corrected, strict=True):
            sink.write(side_by_side(s.rolling, c))
    mid = len(sim) // 2
    write_image(still, side_by_side(sim[mid].rolling, corrected[mid]))
    h, w = sim[0].rolling.shape[:2]
    return {"readout": readout, "speed": speed, "frames": frames, "width": w, "height": h,
            "error_before": err_before, "error_after": err_after,
            "psnr_before": psnr_before, "psnr_after": psnr_after,
            "video": str(output), "still": str(still)}
