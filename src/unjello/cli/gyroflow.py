"""``unjello export-gyroflow``: a motion JSON as a Gyroflow project for the editors' plugins.

:mod:`unjello.cli.commands` adds it to its group (and turns the library's errors into one line).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from ..errors import InputError, SettingsError

__all__ = ["export_gyroflow"]


@click.command("export-gyroflow")
@click.argument("motion", type=click.Path(path_type=Path))
@click.option("-o", "--output", type=click.Path(path_type=Path),
              help="The project, NAME.gyroflow (its log NAME.gcsv goes beside it). Default: "
              "beside the clip, named after it, where the editors' plugins look.")
@click.option("--video", type=click.Path(path_type=Path),
              help="The clip the motion was measured on (default: the one the motion JSON "
              "names).")
@click.option("--fps", type=click.FloatRange(min=0, min_open=True),
              help="Its frame rate (default: the motion JSON's, else the clip's).")
@click.option("--focal", type=click.FloatRange(min=0, min_open=True),
              help="Focal length in pixels of the frame. Default: the lens profile's or the "
              "camera database's, else guessed (70 degrees across the width).")
@click.option("--distortion", help="Fisheye lens distortion k1,k2,k3,k4 (OpenCV's model).")
@click.option("--lens-profile", type=click.Path(path_type=Path),
              help="A Gyroflow lens profile (JSON) for the lens.")
@click.option("--camera", help="Camera, as `unjello cameras` lists it: its lens from the "
              "camera database.")
@click.option("-y", "--overwrite", is_flag=True, help="Replace existing files.")
def export_gyroflow(motion: Path, output: Path | None, video: Path | None, fps: float | None,
                    focal: float | None, distortion: str | None, lens_profile: Path | None,
                    camera: str | None, overwrite: bool) -> None:
    """Write MOTION (from correct --motion-out) as a Gyroflow project and its .gcsv log."""
    from ..config import CorrectionConfig
    from ..exports.gyroflow import export_project, project_lens
    from ..io.source import FrameSource
    from ..io.telemetry import camera_of
    from ..trajectory import Trajectory

    if not motion.is_file():
        raise InputError(f"{motion}: no such file")
    traj = Trajectory.load(motion)
    clip = video or (Path(traj.source) if traj.source else None)
    if clip is None or not clip.exists():
        gone = f" ({traj.source} is not there)" if traj.source else ""
        raise SettingsError(f"give --video: the clip the motion was measured on{gone}")
    with FrameSource(clip) as source:
        info = source.info
        rotation = float(source.reader.info.rotation) if source.reader is not None else 0.0
    rate = fps or traj.fps or info.fps
    if not rate:
        raise SettingsError(f"give --fps: {clip.name} states no frame rate")
    if (info.width, info.height) != tuple(traj.size):
        raise InputError(f"{clip.name} is {info.width}x{info.height}, the motion "
                         f"{traj.size[0]}x{traj.size[1]}: not the clip it was measured on")
    options: dict[str, Any] = {"focal": focal, "distortion": distortion,
                               "lens_profile": lens_profile, "camera": camera}
    config = CorrectionConfig().with_options(
        "command line", **{k: v for k, v in options.items() if v is not None})
    named: str | None = config.camera or (camera_of(clip) if clip.is_file() else None)
    lens = project_lens(config, named, (info.width, info.height), rate)
    project = output or clip.with_suffix(".gyroflow")
    _, said = export_project(traj, project, video=clip, fps=rate, lens=lens,
                             frames=info.frames or len(traj), rotation=rotation,
                             overwrite=overwrite)
    click.echo(said, err=True)
