"""The readout commands: measured from a flicker frame, estimated from footage, looked up.

``unjello readout``, ``unjello estimate-readout`` and ``unjello cameras``;
:mod:`unjello.cli.commands`
adds them to its group (and turns the library's errors into one line).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import click

from ..errors import UnjelloError
from ..timing import DIRECTIONS

__all__ = ["readout", "estimate_readout", "cameras"]


@click.command()
@click.argument("image", type=click.Path(path_type=Path))
@click.option("--frequency", type=click.FloatRange(min=0, min_open=True), required=True,
              help="Flicker frequency in Hz (LED drive frequency, or 100/120 for mains).")
@click.option("--fps", type=click.FloatRange(min=0, min_open=True),
              help="Frame rate, to also print the readout as a fraction of the frame interval.")
@click.option("--direction", type=click.Choice(DIRECTIONS), default="top-bottom",
              show_default=True)
@click.option("--json", "as_json", is_flag=True)
def readout(image: Path, frequency: float, fps: float | None, direction: str,
            as_json: bool) -> None:
    """Measure the readout time from one frame of a light flickering at a known frequency."""
    from ..io.frames import read_image
    from ..readout.flicker import readout_from_flicker

    if not image.exists():
        raise UnjelloError(f"{image}: no such file")
    r = readout_from_flicker(read_image(image), frequency, direction=direction)
    if as_json:
        click.echo(json.dumps({"milliseconds": r.milliseconds, "period_lines": r.period_lines,
                               "lines": r.lines, "contrast": r.contrast,
                               "ratio": r.ratio(fps) if fps else None}))
        return
    line = (f"readout {r.milliseconds:.3f} ms ({r.lines} lines, band period "
            f"{r.period_lines:.2f} lines at {frequency:g} Hz)")
    if fps:
        line += f"; at {fps:g} fps: --readout {r.ratio(fps):.3f}"
    click.echo(line)


@click.command("estimate-readout")
@click.argument("inputs", nargs=-1, required=True, type=click.Path(path_type=Path))
@click.option("--direction", type=click.Choice(DIRECTIONS), default="top-bottom",
              show_default=True)
@click.option("--frames", type=click.IntRange(2, 10000), default=60, show_default=True,
              help="Frames analysed from the start of each input.")
@click.option("--save-preset", type=click.Path(path_type=Path),
              help="Write the (pooled) readout as a preset file for correct --preset.")
@click.option("--focal", type=click.FloatRange(min=0, min_open=True),
              help="The lens's focal length in pixels, where known (else fitted to the "
              "motion).")
@click.option("--distortion", help="Its fisheye distortion k1,k2,k3,k4 (OpenCV's model).")
@click.option("-y", "--overwrite", is_flag=True, help="Replace the preset file.")
@click.option("--json", "as_json", is_flag=True)
def estimate_readout(inputs: tuple[Path, ...], direction: str, frames: int,
                     save_preset: Path | None, focal: float | None, distortion: str | None,
                     overwrite: bool, as_json: bool) -> None:
    """Estimate the readout of INPUTS (videos or folders, one camera mode) from the footage.

    Each is read from its motion and from the lean of its straight lines; several are
    pooled by their uncertainties (a camera mode's readout does not change). A camera
    that turns is fitted as a rotation per scanline through a lens, which is fitted too
    (unless --focal gives it) and printed as the flags that give it to correct.
    """
    from ..config import CorrectionConfig
    from ..io.sink import check_new, replace, temp_path
    from ..lens import Lens
    from ..readout.footage import estimate_clips, lens_flags, readout_preset

    if distortion is not None and focal is None:
        raise UnjelloError("--distortion needs --focal: the lens's focal length in pixels")
    config = CorrectionConfig().with_options(
        "command line", **{k: v for k, v in {"focal": focal, "distortion": distortion}.items()
                           if v is not None})
    lens = Lens(config.gyro.focal, config.gyro.distortion) if config.gyro.focal else None
    if save_preset is not None:
        check_new(save_preset, overwrite)
    rows, best = estimate_clips(inputs, direction=direction, max_frames=frames, lens=lens)
    if save_preset is not None:
        if not best.reliable:
            from ..clip import database_readout

            known = database_readout(inputs[0]) if len(inputs) == 1 else ""
            raise UnjelloError(
                f"no preset written: {best.describe()}"
                + (f". The file names its camera, and correct takes its readout by itself "
                   f"({known})" if known.startswith("camera database") else
                   f". {known}" if known else ". Give correct --readout (ms or a fraction), "
                   "or measure it: unjello readout"))
        tmp = temp_path(save_preset)
        tmp.write_text(json.dumps(readout_preset(best, direction, rows[0][1]), indent=1)
                       + "\n")
        replace(tmp, save_preset)
    if as_json:
        out: dict[str, Any] = best.as_json()
        if len(rows) > 1:
            out["inputs"] = [{"input": str(p), **e.as_json()} for p, _, e in rows]
        click.echo(json.dumps(out))
        return
    for path, _, est in rows:
        click.echo(est.describe() if len(rows) == 1 else f"{path}: {est.describe()}")
        if est.lens is not None and est.reliable and lens is None:
            click.echo(f"  its lens, fitted to the motion: {lens_flags(est.lens)}")
    if len(rows) > 1:
        click.echo(f"pooled over {len(rows)} inputs: {best.describe()}")
    if save_preset is not None:
        click.echo(f"wrote {save_preset}: use it with unjello correct IN -o OUT --preset "
                   f"{save_preset}")


@click.command()
@click.argument("search", nargs=-1)
@click.option("--all", "show_all", is_flag=True, help="Also the modes no profile gives a "
              "readout for.")
@click.option("--size", help="A clip's WIDTHxHEIGHT: also say what correct takes for it "
              "(with --fps), and mark the modes it rests on.")
@click.option("--fps", type=click.FloatRange(min=0, min_open=True), help="A clip's frame rate.")
@click.option("--json", "as_json", is_flag=True, help="One JSON object per mode.")
def cameras(search: tuple[str, ...], show_all: bool, size: str | None, fps: float | None,
            as_json: bool) -> None:
    """List the camera database's modes matching SEARCH (words of brand, model, mode).

    Each mode's readout is the median of its profiles stating one; with --size and --fps
    (as `unjello probe` shows a clip), the line `correct` prints for such a clip follows,
    and the modes it rests on are marked with *.
    """
    from ..readout.cameras import match
    from ..readout.cameras import search as find

    modes = [m for m in find(" ".join(search)) if show_all or m.readout_ms]
    if as_json:
        for m in modes:
            click.echo(json.dumps(dataclasses.asdict(m)))
        return
    if not modes:
        raise UnjelloError(f"no camera in the database matches {' '.join(search)!r}"
                           + ("" if show_all else " with a readout (try --all)"))
    found = None
    if size is not None or fps is not None:
        try:
            w, h = (int(v) for v in (size or "").lower().split("x"))
        except ValueError:
            raise UnjelloError(f"--size must look like 854x480, got {size!r}") from None
        names = {m.name for m in modes}
        if len(names) > 1:
            raise UnjelloError(f"--size and --fps need one camera; {' '.join(search)!r} "
                               f"matches {len(names)}: name one")
        found = match(names.pop(), w, h, fps)
    from rich.console import Console
    from rich.table import Table

    used = set(found.used) if found is not None else set()
    one = len({m.name for m in modes}) == 1  # the camera said once, above the table
    table = Table("", *(() if one else ("camera",)), "mode", "size", "fps", "readout", "scan",
                  "agree", "profiles", box=None, show_edge=False, pad_edge=False)
    for column in table.columns:  # numbers whole; the names wrap where they must
        column.no_wrap = column.header not in ("camera", "mode")
    for m in modes:
        timed = bool(m.readout_ms)
        table.add_row("*" if m in used else "", *(() if one else (m.name,)), m.mode,
                      f"{m.width}x{m.height}", f"{m.fps:g}",
                      f"{abs(m.readout_ms or 0):.4g} ms" if timed else "",
                      ("bottom-top" if (m.readout_ms or 0) < 0 else "top-bottom") if timed
                      else "", f"{m.readout_agree}/{m.readout_n}" if timed else "",
                      str(m.profiles))
    click.echo(f"{modes[0].name + ': ' if one else ''}{len(modes)} mode(s). readout: the "
               "median of the mode's profiles that state one;")
    click.echo("agree: how many of those are within 5 % of it / how many state one.")
    Console().print(table)
    if found is not None:
        click.echo(f"a {size} clip at {fps:g} fps gets: {found.describe()}" if fps else
                   f"a {size} clip gets: {found.describe()}")
