"""The ``unjello`` command line: the only place that prints, draws progress and exits.

Every deliberate error (:class:`~unjello.errors.UnjelloError`) becomes one line on
stderr and exit code 2; Ctrl-C exits with 130 after the pipeline removed its temporary
output.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from functools import partial
from pathlib import Path
from typing import Any

import click
import numpy as np

from . import __version__
from .errors import UnjelloError
from .io.video import EncodeOptions
from .timing import DIRECTIONS, REFERENCES, SensorTiming, parse_readout

__all__ = ["main", "cli"]


PRESETS: dict[str, dict[str, Any]] = {
    # The paper's own output: its method, forward splatting, black where nothing lands.
    "paper-figures": {"method": "paper", "warp": "splat", "fill": "black"},
    # Transcode-rate speed: the camera trajectory alone (no per-pixel parallax), from
    # DIS "ultrafast" flow on a 320 px copy; the encoder settings stay as given.
    "fast": {"camera_only": True, "flow_preset": "ultrafast", "work_width": 320},
    # Drones and vehicles: vibration near the frame rate (see --vibration).
    "drone": {"vibration": "on"},
}
_PRESET_KEYS = ("readout", "direction", "reference", "method", "warp", "fill", "search",
                "flow_preset", "work_width", "camera_only", "edge_refine", "vibration", "codec",
                "crf", "x264_preset")


def _apply_preset(ctx: click.Context, preset: str) -> dict[str, Any]:
    """Merge a named or JSON preset under the options given on the command line."""
    from click.core import ParameterSource

    from .errors import SettingsError

    if preset in PRESETS:
        values = dict(PRESETS[preset])
    else:
        path = Path(preset)
        if not path.exists():
            raise SettingsError(f"unknown preset {preset!r}: use one of {', '.join(PRESETS)} "
                                "or a JSON file")
        try:
            values = json.loads(path.read_text())
        except ValueError as exc:
            raise SettingsError(f"preset {path}: not valid JSON ({exc})") from None
        if not isinstance(values, dict):
            raise SettingsError(f"preset {path}: must be a JSON object")
    values = {k.replace("-", "_"): v for k, v in values.items()}
    unknown = sorted(set(values) - set(_PRESET_KEYS))
    if unknown:
        raise SettingsError(f"preset {preset}: unknown key(s) {', '.join(unknown)}")
    out = {}
    for key in _PRESET_KEYS:
        given = ctx.get_parameter_source(key) == ParameterSource.COMMANDLINE
        out[key] = ctx.params[key] if given or key not in values else values[key]
    return out


@contextmanager
def _progress(label: str, quiet: bool) -> Iterator[Callable[[int, int], None] | None]:
    """Yield a Rich progress callback on a terminal, None otherwise."""
    if quiet or not sys.stderr.isatty():
        yield None
        return
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeRemainingColumn,
    )

    with Progress(TextColumn(label), BarColumn(), MofNCompleteColumn(),
                  TextColumn("{task.fields[fps]:.1f} fps"), TimeRemainingColumn(),
                  transient=True) as bar:
        task = bar.add_task(label, total=None, fps=0.0)

        def update(done: int, total: int) -> None:
            elapsed = bar.tasks[0].elapsed or 1e-9
            bar.update(task, completed=done, total=total or None, fps=done / elapsed)

        yield update


def _readout_option(f: Callable, simulated: bool = False) -> Callable:
    if simulated:
        return click.option("--readout", default=None,
                            help="Readout time of the simulated sensor: fraction of the frame "
                                 "interval (0 < r <= 1) or milliseconds (15.7ms). Default "
                                 "1.0.")(f)
    return click.option("--readout", default=None,
                        help="Readout time: fraction of the frame interval (0 < r <= 1), "
                             "milliseconds (15.7ms), or 'auto' (stated by the file, else "
                             "estimated from the motion). Default: what a sidecar or the "
                             "file's metadata states, else 1.0.")(f)


def _timing_options(f: Callable, simulated: bool = False) -> Callable:
    f = click.option("--reference", type=click.Choice(REFERENCES), default="middle",
                     show_default=True, help="Scanline whose time the output shows.")(f)
    f = click.option("--direction", type=click.Choice(DIRECTIONS), default="top-bottom",
                     show_default=True, help="Order the sensor reads its lines (coded "
                                             "orientation).")(f)
    return _readout_option(f, simulated)


def _settings_options(f: Callable) -> Callable:
    """Options shared by ``correct`` and ``batch``: timing, method, warp, encoder, preset."""
    for opt in reversed([
        click.option("--method", type=click.Choice(["dense", "paper", "gyro"]), default="dense",
                     show_default=True,
                     help="Motion model: 'dense' = per-pixel flow with a scanline-resolution "
                          "camera trajectory; 'paper' = Liang, Chang & Chen 2008; 'gyro' = "
                          "a rotation per scanline from a gyro log (--gyro)."),
        click.option("--warp", type=click.Choice(["remap", "splat"]), default="remap",
                     show_default=True,
                     help="Backward remap (fast) or the paper's forward splat."),
        click.option("--fill", type=click.Choice(["nearest", "black"]), default="nearest",
                     show_default=True, help="What fills the area no scanline reaches."),
        click.option("--search", type=click.IntRange(1, 1000), default=160,
                     show_default=True,
                     help="Global block-matching search range, px (paper: 160)."),
        click.option("--flow-preset", type=click.Choice(["ultrafast", "fast", "medium"]),
                     default="medium", show_default=True,
                     help="Dense method: DIS optical flow preset (speed vs accuracy)."),
        click.option("--work-width", type=click.IntRange(0, 100000), default=480,
                     show_default=True,
                     help="Dense method: estimate motion on frames at most this wide "
                          "(0: full)."),
        click.option("--camera-only", is_flag=True,
                     help="Dense method: camera trajectory only, one displacement per "
                          "scanline (fast; no per-pixel parallax or moving objects)."),
        click.option("--edge-refine", is_flag=True,
                     help="Dense method: near motion boundaries (parallax, moving objects) "
                          "give each pixel the flow of the side it matches; a third less "
                          "motion error there (--stmap, --motion-out), up to a third slower."),
        click.option("--vibration", type=click.Choice(["auto", "on", "off"]), default="auto",
                     show_default=True,
                     help="Dense method: follow vibration near the frame rate (drone jello) "
                          "with a 1 s window (best on clips of 2 s or more); 'auto' turns it "
                          "on when the first frames wobble."),
        click.option("--preset",
                     help="Named settings (" + ", ".join(PRESETS) + ") or a JSON file with "
                          "the same keys as these options; the command line wins."),
        click.option("--codec", default="libx264", show_default=True),
        click.option("--crf", type=click.IntRange(0, 51), default=18, show_default=True),
        click.option("--x264-preset", default="medium", show_default=True,
                     help="Encoder speed/size preset (ultrafast ... veryslow)."),
    ]):
        f = opt(f)
    return _timing_options(f)


def _gyro_options(f: Callable) -> Callable:
    """Options of the gyro method (``correct`` only: a log belongs to one clip)."""
    for opt in reversed([
        click.option("--gyro", type=click.Path(path_type=Path),
                     help="Gyro log of the clip (text or CSV: a time and three angular rates "
                          "per line); implies --method gyro."),
        click.option("--gyro-layout", default="auto", show_default=True,
                     help="Column order of the log, e.g. t,x,y,z or x,y,z,t; auto: the "
                          "increasing column is the time."),
        click.option("--gyro-units", type=click.Choice(["rad", "deg"]), default="rad",
                     show_default=True, help="Unit of the logged rates (per second)."),
        click.option("--gyro-axes", default="auto", show_default=True,
                     help="Camera x, y, z as gyro axes, e.g. XYZ or yXz (lower case: "
                          "negated); auto: found from the footage's motion."),
        click.option("--gyro-offset", type=float,
                     help="Time on the log's clock of the first frame, ms; default: found "
                          "from the footage's motion."),
        click.option("--focal", type=click.FloatRange(min=0, min_open=True),
                     help="Focal length in pixels of the frame; default: found from the "
                          "footage's motion."),
        click.option("--fps", type=click.FloatRange(min=0, min_open=True), default=30.0,
                     show_default=True,
                     help="Frame rate of a folder of frames, for the gyro method (a video "
                          "states its own)."),
    ]):
        f = opt(f)
    return f


def _settings(options: dict[str, Any]) -> tuple[str | None, str, str, Any, EncodeOptions]:
    """Apply ``--preset`` and build the correction settings from the shared options.

    Returns
    -------
    readout, direction, reference, CorrectionConfig, EncodeOptions
    """
    from .errors import SettingsError
    from .motion.dense import VIBRATION, DenseConfig
    from .motion.global_motion import BlockMatchConfig
    from .motion.gyro import GyroConfig
    from .motion.paper import PaperConfig
    from .pipeline import CorrectionConfig

    v = dict(options)
    preset = v.pop("preset", None)
    if preset:
        v.update(_apply_preset(click.get_current_context(), preset))
    vibration = {True: "on", False: "off"}.get(v["vibration"], v["vibration"])
    if vibration not in ("auto", "on", "off"):
        raise SettingsError(f"vibration must be auto, on or off, not {vibration!r}")
    method = v["method"]
    gyro = GyroConfig()
    if "gyro" in v:  # correct's gyro options (a log of its own, or NAME.gyro.csv beside it)
        if v["gyro"] is not None:
            if method == "paper":
                raise SettingsError("--gyro goes with --method gyro, not paper")
            method = "gyro"
        offset = v["gyro_offset"]
        gyro = GyroConfig(path=None if v["gyro"] is None else str(v["gyro"]),
                          layout=v["gyro_layout"], units=v["gyro_units"], axes=v["gyro_axes"],
                          offset=None if offset is None else offset / 1e3, focal=v["focal"],
                          fps=v["fps"])
    config = CorrectionConfig(method=method, warp=v["warp"], fill=v["fill"],
                              paper=PaperConfig(BlockMatchConfig(search=v["search"])),
                              dense=DenseConfig(flow_preset=v["flow_preset"],
                                                work_width=v["work_width"],
                                                per_pixel=not v["camera_only"],
                                                edge_refine=v["edge_refine"],
                                                detect_vibration=vibration == "auto",
                                                **(VIBRATION if vibration == "on" else {})),
                              gyro=gyro)
    return (v["readout"], v["direction"], v["reference"], config,
            EncodeOptions(v["codec"], v["crf"], v["x264_preset"]))


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="unjello")
def cli() -> None:
    """Remove rolling-shutter distortion (skew, wobble, jello) from video."""


@cli.command()
@click.argument("input", type=click.Path(path_type=Path))
@click.option("-o", "--output", type=click.Path(path_type=Path), required=True,
              help="Output video, or folder for a folder input.")
@_settings_options
@_gyro_options
@click.option("--motion-out", type=click.Path(path_type=Path),
              help="Write the estimated motion as JSON (schema unjello.trajectory v1).")
@click.option("--motion-in", type=click.Path(path_type=Path),
              help="Apply a motion JSON from --motion-out instead of estimating it.")
@click.option("--preview", type=click.Path(path_type=Path),
              help="Also write a side-by-side video: input left, corrected right.")
@click.option("--stmap", type=click.Path(path_type=Path),
              help="Folder for per-frame 16-bit STMap PNGs (Nuke, Resolve/Fusion, AE).")
@click.option("--json", "as_json", is_flag=True,
              help="Print one JSON summary line on stdout.")
@click.option("-y", "--overwrite", is_flag=True, help="Replace an existing output.")
@click.option("-q", "--quiet", is_flag=True, help="No progress bar.")
def correct(input: Path, output: Path, motion_out: Path | None, motion_in: Path | None,
            preview: Path | None, stmap: Path | None, as_json: bool, overwrite: bool,
            quiet: bool, **options: Any) -> None:
    """Correct INPUT (a video, or a folder of frames) into OUTPUT."""
    import time

    from .pipeline import correct_video

    readout, direction, reference, config, encode = _settings(options)
    if readout is not None and str(readout).strip().lower() != "auto" and not input.is_dir():
        parse_readout(str(readout), 30.0)  # validate early, before opening anything
    messages: list[str] = []

    def log(m: str) -> None:
        messages.append(m)
        if not quiet or m.startswith("warning"):
            click.echo(m, err=True)

    t0 = time.perf_counter()
    with _progress("correcting", quiet or as_json) as progress:
        traj = correct_video(input, output, readout=readout, direction=direction,
                             reference=reference, config=config, encode=encode,
                             overwrite=overwrite,
                             motion_out=motion_out, progress=progress, log=log,
                             motion_in=motion_in, preview=preview, stmap=stmap)
    seconds = time.perf_counter() - t0
    bad = sum(not f.ok for f in traj.frames)
    if bad and len(traj) > 1:
        log(f"warning: motion bridged over on {bad} frame(s)")
    if traj.method == "gyro" and len(traj):
        log(traj.frames[0].note)  # the calibration: axes, offset, focal length, agreement
    detected = next((f.note.split(";")[0] for f in traj.frames
                     if f.note.startswith("vibration detected")), None)
    if detected:
        log(f"{detected}, as with --vibration on (--vibration off: never)")
    fallback = float(np.mean([f.fallback for f in traj.frames])) if len(traj) else 0.0
    if fallback > 0.1:
        log(f"warning: the flow was unreliable on {100 * fallback:.0f}% of the pixels (flat "
            "areas, occlusions); they follow the camera's motion instead")
    if as_json:
        click.echo(json.dumps({
            "input": str(input), "output": str(output), "frames": len(traj),
            "method": traj.method, "readout": traj.timing.readout,
            "direction": traj.timing.direction, "reference": traj.timing.reference,
            "seconds": round(seconds, 3), "fps": round(len(traj) / max(seconds, 1e-9), 2),
            "bridged_frames": bad, "fallback_fraction": round(fallback, 4),
            "messages": messages}))
    elif not quiet:
        click.echo(f"wrote {output} ({len(traj)} frames, readout {traj.timing.readout:g}, "
                   f"{len(traj) / max(seconds, 1e-9):.1f} fps)", err=True)


@cli.command()
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
    from .io.frames import read_image
    from .readout import readout_from_flicker

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


@cli.command("estimate-readout")
@click.argument("input", type=click.Path(path_type=Path))
@click.option("--direction", type=click.Choice(DIRECTIONS), default="top-bottom",
              show_default=True)
@click.option("--frames", type=click.IntRange(3, 10000), default=60, show_default=True,
              help="Frames analysed from the start.")
@click.option("--json", "as_json", is_flag=True)
def estimate_readout(input: Path, direction: str, frames: int, as_json: bool) -> None:
    """Estimate the readout ratio of INPUT (video or folder) from its motion."""
    from .pipeline import estimate_readout_file

    est = estimate_readout_file(input, direction=direction, max_frames=frames)
    if as_json:
        click.echo(json.dumps({"readout": est.readout, "confidence": est.confidence,
                               "reliable": est.reliable, "model": est.model,
                               "candidates": est.candidates.tolist(),
                               "costs": est.costs.tolist()}))
        return
    if est.reliable:
        click.echo(f"readout {est.readout:.3f} of the frame interval "
                   f"(confidence {est.confidence:.2f}, {est.model} motion model)")
    else:
        click.echo(f"readout unknown: the motion is too weak or too uniform to tell "
                   f"(confidence {est.confidence:.2f}); default {est.readout:g}")


@cli.command()
@click.argument("source", type=click.Path(path_type=Path))
@click.option("-o", "--output", type=click.Path(path_type=Path), required=True,
              help="Rolling-shutter clip to write (.mp4 or a folder).")
@click.option("--truth", type=click.Path(path_type=Path), required=True,
              help="Global-shutter truth to write (.mp4 or a folder).")
@click.option("--truth-motion", type=click.Path(path_type=Path),
              help="True trajectory JSON (default <truth>.motion.json).")
@click.option("--motion", default="pan", show_default=True,
              help="pan, stop, diagonal, shake, jello, or a JSON trajectory file.")
@partial(_timing_options, simulated=True)
@click.option("--frames", type=click.IntRange(1, 100000), default=30, show_default=True)
@click.option("--fps", type=float, help="Frame rate (default: the source's, else 30).")
@click.option("--size", help="Output WIDTHxHEIGHT.")
@click.option("--speed", type=float, default=8.0, show_default=True, help="Pan px/frame.")
@click.option("--amplitude", type=float, default=1.0, show_default=True,
              help="Scale of shake/jello.")
@click.option("--exposure", type=click.FloatRange(0, 1), default=0.0, show_default=True,
              help="Exposure time as a fraction of the frame interval (motion blur).")
@click.option("--crf", type=click.IntRange(0, 51), default=18, show_default=True)
@click.option("--gyro-out", type=click.Path(path_type=Path),
              help="Also write a gyro log of the motion (CSV, 400 Hz; for --method gyro).")
@click.option("-y", "--overwrite", is_flag=True)
def simulate(source: Path, output: Path, truth: Path, truth_motion: Path | None, motion: str,
             readout: str | None, direction: str, reference: str, frames: int, fps: float | None,
             size: str | None, speed: float, amplitude: float, exposure: float, crf: int,
             gyro_out: Path | None, overwrite: bool) -> None:
    """Render a rolling-shutter clip and its truth from an image or a GS video."""
    from .errors import SettingsError
    from .pipeline import simulate_clip

    wh = None
    if size:
        try:
            w, h = (int(v) for v in size.lower().split("x"))
            wh = (w, h)
        except ValueError:
            raise SettingsError(f"--size must look like 640x480, got {size!r}") from None
    timing = SensorTiming(parse_readout(readout or "1.0", fps or 30.0),  # type: ignore[arg-type]
                          direction, reference)  # type: ignore[arg-type]
    simulate_clip(source, output, truth, motion=motion, timing=timing, frames=frames, fps=fps,
                  size=wh, speed=speed, amplitude=amplitude, exposure=exposure,
                  overwrite=overwrite, truth_motion=truth_motion,
                  encode=EncodeOptions(crf=crf), gyro_out=gyro_out)
    click.echo(f"wrote {output} and {truth}", err=True)


@cli.command()
@click.argument("output", type=click.Path(path_type=Path))
@click.argument("truth", type=click.Path(path_type=Path))
@click.option("--motion", type=click.Path(path_type=Path),
              help="Estimated trajectory (from correct --motion-out).")
@click.option("--true-motion", type=click.Path(path_type=Path),
              help="True trajectory (default <truth>.motion.json if present).")
@click.option("--margin", type=click.IntRange(0, 10000), default=0, show_default=True,
              help="Pixels cropped from every side before PSNR/SSIM.")
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of a table.")
def evaluate(output: Path, truth: Path, motion: Path | None, true_motion: Path | None,
             margin: int, as_json: bool) -> None:
    """Score OUTPUT against global-shutter TRUTH: PSNR, SSIM, displacement error."""
    from .pipeline import evaluate as run

    rows = run(output, truth, motion=motion, true_motion=true_motion, margin=margin)
    keys = [k for k in ("psnr", "ssim", "displacement_error", "uncorrected_error")
            if k in rows[0]]
    mean = {k: float(np.mean([r[k] for r in rows if k in r])) for k in keys}
    if as_json:
        click.echo(json.dumps({"frames": rows, "mean": mean}))
        return
    click.echo("frame " + " ".join(f"{k:>18}" for k in keys))
    for r in rows:
        click.echo(f"{r['frame']:5d} " + " ".join(f"{r[k]:18.4f}" if k in r else " " * 18
                                                  for k in keys))
    click.echo(" mean " + " ".join(f"{mean[k]:18.4f}" for k in keys))


@cli.command()
@click.option("-o", "--output", type=click.Path(path_type=Path),
              default=Path("unjello_demo.mp4"), show_default=True,
              help="Side-by-side before/after video; a PNG still is written beside it.")
@click.option("--frames", type=click.IntRange(4, 1000), default=36, show_default=True)
@click.option("-y", "--overwrite", is_flag=True)
def demo(output: Path, frames: int, overwrite: bool) -> None:
    """Render a rolling-shutter clip from a built-in image, correct it, show before/after."""
    from .demo import run_demo

    report = run_demo(output, frames=frames, overwrite=overwrite)
    click.echo(f"rolling-shutter clip: readout {report['readout']:g}, diagonal pan "
               f"{report['speed']:g} px/frame, {report['frames']} frames "
               f"({report['width']}x{report['height']})")
    click.echo(f"mean per-scanline displacement error: before {report['error_before']:.3f} px, "
               f"after {report['error_after']:.3f} px "
               f"({report['error_before'] / max(report['error_after'], 1e-9):.0f}x lower)")
    click.echo(f"PSNR vs global-shutter truth: before {report['psnr_before']:.2f} dB, "
               f"after {report['psnr_after']:.2f} dB")
    click.echo(f"wrote {report['video']} (left: input, right: corrected) and {report['still']}")


@cli.command()
@click.argument("inputs", nargs=-1, required=True)
@click.option("-o", "--output", "out_dir", type=click.Path(path_type=Path), required=True,
              help="Output folder; outputs are named after the inputs.")
@_settings_options
@click.option("--executor", "kind", type=click.Choice(["local", "dask", "ray"]),
              default="local", show_default=True,
              help="Local process pool, or an existing/local Dask or Ray cluster.")
@click.option("--address", help="Dask scheduler or Ray cluster address (default: local).")
@click.option("--workers", type=click.IntRange(1, 4096), help="Local workers (default: cores).")
@click.option("--report", type=click.Path(path_type=Path),
              help="JSON-lines report (default OUT_DIR/unjello-batch.jsonl).")
@click.option("-y", "--overwrite", is_flag=True, help="Redo clips whose output exists.")
@click.option("-q", "--quiet", is_flag=True)
def batch(inputs: tuple[str, ...], out_dir: Path, kind: str, address: str | None,
          workers: int | None, report: Path | None, overwrite: bool, quiet: bool,
          **settings: Any) -> None:
    """Correct many clips (files, folders, globs) into OUT_DIR; resumable."""
    from .batch import run_batch

    readout, direction, reference, config, encode = _settings(settings)
    if readout is not None and readout.strip().lower() != "auto":
        parse_readout(readout, 30.0)
    options = {"readout": readout, "direction": direction, "reference": reference,
               "config": config, "encode": encode}

    def show(row: dict) -> None:
        if not quiet:
            extra = f" ({row['error']})" if row["error"] else ""
            click.echo(f"{row['status']:8} {row['input']} {row['seconds']:.1f} s{extra}",
                       err=True)

    rows = run_batch(inputs, out_dir, kind=kind, address=address, workers=workers,
                     overwrite=overwrite, report=report, options=options, on_result=show)
    failed = sum(r["status"] == "failed" for r in rows)
    done = sum(r["status"] == "ok" for r in rows)
    skipped = sum(r["status"] == "skipped" for r in rows)
    click.echo(f"{done} corrected, {skipped} skipped, {failed} failed", err=True)
    if failed:
        sys.exit(1)


@cli.command()
@click.argument("motion", type=click.Path(path_type=Path))
@click.option("-o", "--output", type=click.Path(path_type=Path), required=True,
              help="Image to write (PNG).")
@click.option("-y", "--overwrite", is_flag=True)
def plot(motion: Path, output: Path, overwrite: bool) -> None:
    """Plot a motion JSON: per-scanline displacement and velocity over time."""
    from .errors import OutputError
    from .exports import plot_trajectory
    from .trajectory import Trajectory

    if output.exists() and not overwrite:
        raise OutputError(f"{output} exists; pass -y to overwrite it")
    plot_trajectory(Trajectory.load(motion), output)
    click.echo(f"wrote {output}", err=True)


@cli.command()
@click.argument("input", type=click.Path(path_type=Path))
@click.option("--json", "as_json", is_flag=True)
def probe(input: Path, as_json: bool) -> None:
    """Describe a video: size, rate (and whether it varies), rotation, audio, format."""
    from .io.video import probe as run_probe
    from .io.video import variable_rate
    from .readout import stated_readout

    info = run_probe(input)
    vfr = variable_rate(input)
    stated = stated_readout(input)
    doc = {"path": str(input), "width": info.width, "height": info.height,
           "fps": round(info.fps, 4), "variable_frame_rate": vfr, "frames": info.frames,
           "duration": round(info.duration, 3), "codec": info.codec, "pix_fmt": info.pix_fmt,
           "bit_depth": info.bit_depth, "rotation": info.rotation,
           "audio_streams": info.audio_streams,
           "readout_ms": stated.milliseconds if stated else None,
           "readout_source": stated.source if stated else None,
           "color": {k: (str(v) if v is not None else None) for k, v in info.color.items()}}
    if as_json:
        click.echo(json.dumps(doc))
        return
    click.echo(f"{input}: {info.width}x{info.height} {info.codec} {info.pix_fmt} "
               f"({info.bit_depth}-bit), {info.fps:.3f} fps{' (variable)' if vfr else ''}, "
               f"{info.frames} frames, {info.duration:.2f} s")
    click.echo(f"rotation {info.rotation} deg, {info.audio_streams} audio stream(s)")
    if stated:
        ratio = stated.milliseconds * 1e-3 * info.fps
        click.echo(f"readout: {stated.milliseconds:g} ms ({ratio:.3f} of the frame interval), "
                   f"from the {stated.source}")
    else:
        click.echo("readout: not stated by the file or a sidecar; measure it (unjello readout), "
                   "estimate it (unjello estimate-readout) or pass --readout")


def main(argv: list[str] | None = None) -> Any:
    """Entry point: run the CLI, turning deliberate errors into one line and an exit code."""
    try:
        return cli.main(args=argv, prog_name="unjello", standalone_mode=False)
    except click.exceptions.Abort:
        click.echo("interrupted", err=True)
        sys.exit(130)
    except KeyboardInterrupt:
        click.echo("interrupted; partial output removed", err=True)
        sys.exit(130)
    except click.exceptions.ClickException as exc:
        exc.show()
        sys.exit(exc.exit_code)
    except UnjelloError as exc:
        click.echo(f"unjello: error: {exc}", err=True)
        sys.exit(2)
