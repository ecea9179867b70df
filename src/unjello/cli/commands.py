"""The ``unjello`` command line: the only place that prints, draws progress and exits.

Every deliberate error (:class:`~unjello.errors.UnjelloError`) becomes one line on
stderr and exit code 2; Ctrl-C exits with 130 after the pipeline removed its temporary
output.
"""

from __future__ import annotations

import errno
import gc
import json
import os
import re
import signal
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import click
import numpy as np
from click.core import ParameterSource

from .. import __version__
from ..config import OPTIONS, PRESETS, CorrectionConfig
from ..errors import SettingsError, UnjelloError
from ..io.video import EncodeOptions
from ..summary import summarize
from ..timing import DIRECTIONS, REFERENCES, SensorTiming, parse_readout
from .gyroflow import export_gyroflow
from .readout import cameras, estimate_readout, readout

__all__ = ["main", "cli"]


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


def _timing_options(f: Callable) -> Callable:
    """``--readout``, ``--direction``, ``--reference`` of the simulator."""
    f = click.option("--reference", type=click.Choice(REFERENCES), default="middle",
                     show_default=True, help="Scanline whose time the truth shows.")(f)
    f = click.option("--direction", type=click.Choice(DIRECTIONS), default="top-bottom",
                     show_default=True, help="Order the sensor reads its lines.")(f)
    return click.option("--readout", default="1.0", show_default=True,
                        help="Readout time of the simulated sensor: fraction of the frame "
                             "interval (0 < r <= 1) or milliseconds (15.7ms).")(f)


_METAVARS = {"int": "INTEGER", "float": "NUMBER", "path": "PATH"}


def _config_options(per_clip: bool) -> Callable[[Callable], Callable]:
    """Add one flag per :data:`unjello.config.OPTIONS` entry, and ``--preset``.

    The flags carry no defaults and no checks of their own: what is not given on the
    command line comes from the preset, else from
    :class:`~unjello.config.CorrectionConfig`'s defaults (shown in ``--help``), and what
    is given is read and checked by the library.
    """
    defaults = CorrectionConfig()

    def decorate(f: Callable) -> Callable:
        f = click.option("--preset",
                         help="Named settings (" + ", ".join(PRESETS) + ") or a JSON file "
                              "of these options' names and values; the command line wins.")(f)
        for opt in reversed(list(OPTIONS.values())):
            if opt.per_clip and not per_clip:
                continue
            default = defaults.option(opt.name)
            help_text = opt.help + (f" [default: {default}]" if default not in (None, False)
                                    else "")
            if opt.kind == "flag":
                f = click.option(opt.flag, opt.name, is_flag=True, default=None,
                                 help=help_text)(f)
            else:  # text: the library reads and checks it (CorrectionConfig.with_options)
                metavar = ("[" + "|".join(opt.choices) + "]" if opt.choices else
                           _METAVARS.get(opt.kind, "TEXT"))
                f = click.option(opt.flag, opt.name, default=None, help=help_text,
                                 metavar=metavar)(f)
        return f

    return decorate


def _config(preset: str | None, options: dict[str, Any]) -> CorrectionConfig:
    """Build the settings: the preset (or the defaults) under the flags given."""
    ctx = click.get_current_context()
    given = {name: value for name, value in options.items()
             if ctx.get_parameter_source(name) in (ParameterSource.COMMANDLINE,
                                                   ParameterSource.ENVIRONMENT)}
    base = CorrectionConfig.from_preset(preset) if preset else CorrectionConfig()
    return base.with_options(origin="command line", **given)


def _flagify(message: str) -> str:
    """Say a library message in flags: ``overwrite=True`` -> ``-y``, ``gyro=`` -> ``--gyro``."""
    message = message.replace("pass overwrite=True to replace it", "pass -y to overwrite it")
    message = message.replace("overwrite=True", "-y")

    def flag(m: re.Match, gap: str) -> str:
        return OPTIONS[m.group(1)].flag + gap if m.group(1) in OPTIONS else m.group(0)

    message = re.sub(r"\b([a-z][a-z0-9_]*)=(?=[\w'\"])", lambda m: flag(m, " "), message)
    return re.sub(r"\b([a-z][a-z0-9_]*)=", lambda m: flag(m, ""), message)


class _Group(click.Group):
    """Click's group, with every deliberate library error said in one line (exit code 2)."""

    def invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except UnjelloError as exc:
            click.echo(f"unjello: error: {_flagify(str(exc))}", err=True)
            ctx.exit(2)
        except OSError as exc:  # (Click would end a broken pipe silently)
            if exc.errno == errno.EPIPE:
                _reader_gone()
            # A file the system refused that no check foresaw: one line, not a traceback.
            where = f"{exc.filename}: " if exc.filename else ""
            click.echo(f"unjello: error: {where}{exc.strerror or exc}", err=True)
            ctx.exit(2)


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="unjello")
def cli() -> None:
    """Remove rolling-shutter distortion (skew, wobble, jello) from video."""


@cli.command()
@click.argument("input", type=click.Path(path_type=Path))
@click.option("-o", "--output", type=click.Path(path_type=Path), required=True,
              help="Output video, folder (for a folder), or - for stdout (--format).")
@_config_options(per_clip=True)
@click.option("--motion-out", type=click.Path(path_type=Path),
              help="Write the estimated motion as JSON (schema unjello.trajectory v1).")
@click.option("--motion-in", type=click.Path(path_type=Path),
              help="Apply a motion JSON from --motion-out instead of estimating it.")
@click.option("--preview", type=click.Path(path_type=Path),
              help="Also write a side-by-side video: input left, corrected right.")
@click.option("--stmap", type=click.Path(path_type=Path),
              help="Folder for per-frame 16-bit STMap PNGs (Nuke, Resolve/Fusion, AE).")
@click.option("--gyroflow-out", type=click.Path(path_type=Path),
              help="Also write the motion as a Gyroflow project, NAME.gyroflow, with its "
              "log NAME.gcsv beside it: the Resolve, After Effects and Premiere plugins "
              "correct the original clip from them.")
@click.option("--json", "as_json", is_flag=True,
              help="Print one JSON summary line on stdout.")
@click.option("--segments", help="Correct a long video in this many segments (cut at "
              "keyframes; 'auto': one per worker, or per 300 frames) on --executor's workers, "
              "joined without re-encoding; a rerun redoes only unfinished segments.")
@click.option("--executor", "executor_kind", type=click.Choice(["local", "dask", "ray"]),
              help="Where the segments run: local processes, a Dask or a Ray cluster "
              "(local unless --address); implies --segments auto.")
@click.option("--address", help="The cluster's address (Dask tcp://host:8786, Ray "
              "ray://host:10001 or auto).")
@click.option("--workers", type=click.IntRange(1, 4096),
              help="Worker processes of a local pool or cluster (default: the cores).")
@click.option("-y", "--overwrite", is_flag=True, help="Replace an existing output.")
@click.option("-q", "--quiet", is_flag=True, help="No progress bar.")
def correct(input: Path, output: Path, preset: str | None, motion_out: Path | None,
            motion_in: Path | None, preview: Path | None, stmap: Path | None,
            gyroflow_out: Path | None, as_json: bool,
            segments: str | None, executor_kind: str | None, address: str | None,
            workers: int | None, overwrite: bool, quiet: bool, **options: Any) -> None:
    """Correct INPUT (a video, a folder of frames, or - for a stream on stdin) into OUTPUT."""
    from ..pipeline import correct_video

    config = _config(preset, options)
    messages: list[str] = []
    runner: Callable[..., Any] = correct_video
    if str(output) == "-":  # standard output: the video goes there, all else to stderr
        if sys.stdout.isatty():
            raise SettingsError("standard output is a terminal: pipe it into a program "
                                "(| ffmpeg -i - ...) or give -o a file")
        if as_json:
            raise SettingsError("--json prints to standard output, which carries the video "
                                "with -o -")
        ctx = click.get_current_context()
        if (ctx.get_parameter_source("codec") not in (ParameterSource.COMMANDLINE,
                                                      ParameterSource.ENVIRONMENT)
                and config.encode.codec == "libx264"):
            config = config.with_options(codec="rawvideo")  # uncompressed unless asked
    if segments is not None or executor_kind is not None or address is not None:
        if segments is not None and segments != "auto" and not (
                segments.isdigit() and int(segments) >= 1):
            raise click.BadParameter(f"{segments!r}: a number of segments, or auto",
                                     param_hint="--segments")
        taken = [flag for flag, value in (("--motion-out", motion_out),
                                          ("--motion-in", motion_in),
                                          ("--preview", preview), ("--stmap", stmap),
                                          ("--gyroflow-out", gyroflow_out))
                 if value is not None]
        if taken:
            raise SettingsError(f"{', '.join(taken)} cannot be written by a segmented run "
                                "(leave out --segments and --executor)")

        def runner(src: Path, dst: Path, cfg: CorrectionConfig, **kw: Any) -> Any:
            from ..run.segments import correct_segmented

            return correct_segmented(
                src, dst, cfg, segments=segments or "auto", kind=executor_kind or "local",
                address=address, workers=workers, overwrite=kw["overwrite"], log=kw["log"],
                on_timing=kw["on_timing"], progress=kw["progress"])[0]

    def log(m: str) -> None:
        m = _flagify(m)
        messages.append(m)
        if not quiet or m.startswith("warning"):
            click.echo(m, err=True)

    decided: dict[str, Any] = {"gyro": None}
    t0 = time.perf_counter()
    with _progress("correcting", quiet or as_json) as progress:
        traj = runner(input, output, config, overwrite=overwrite,
                             motion_out=motion_out, motion_in=motion_in, preview=preview,
                             stmap=stmap, gyroflow_out=gyroflow_out, progress=progress,
                             log=log,
                             on_timing=lambda r: decided.update(
                                 fps=r.fps, sources=dict(r.sources), estimate=r.estimate),
                             on_gyro=lambda g: decided.update(gyro=g))
    seconds = time.perf_counter() - t0
    stab = config.stabilize
    found = summarize(traj, (stab.smoothness, stab.crop) if stab.enabled else None)
    for line in found.warnings():
        log(line)
    if as_json:
        est = decided.get("estimate")
        click.echo(json.dumps({
            "input": str(input), "output": str(output), **found.as_json(traj),
            "seconds": round(seconds, 3), "fps": round(len(traj) / max(seconds, 1e-9), 2),
            "frame_rate": decided["fps"], "sources": decided["sources"],
            "readout_estimate": est.as_json(costs=False) if est is not None else None,
            "gyro": decided["gyro"], "messages": messages}))
    elif not quiet:
        also = [f"{p} ({what})" for p, what in ((preview, "side by side"),
                                                 (motion_out, "motion"), (stmap, "STMaps"),
                                                 (gyroflow_out, "Gyroflow project"))
                if p is not None]
        click.echo(f"wrote {output} ({len(traj)} frames, readout {traj.timing.readout:.4g} "
                   f"({decided['sources']['readout']}), "
                   f"{len(traj) / max(seconds, 1e-9):.1f} fps)"
                   + "".join(f" and {a}" for a in also), err=True)


@cli.command()
@click.argument("input", type=click.Path(path_type=Path))
@_config_options(per_clip=True)
@click.option("--port", type=click.IntRange(1, 65535), default=8000, show_default=True,
              help="Port of the page on this machine (127.0.0.1 only).")
@click.option("--no-browser", is_flag=True, help="Do not open the page in a browser.")
@click.option("--max-frames", type=click.IntRange(2, 1_000_000), default=1800,
              show_default=True, help="Frames held, from the start.")
def preview(input: Path, preset: str | None, port: int, no_browser: bool, max_frames: int,
            **options: Any) -> None:
    """Tune the settings by eye: a local web page that corrects the frame you look at.

    The page shows the input and the corrected frame side by side, re-rendered as the
    readout, direction, reference or method change, and gives the `unjello correct`
    command (or a preset file) for the settings chosen. The other options set where it
    starts.
    """
    import socket
    import threading
    import webbrowser

    import uvicorn

    from ..preview import PreviewClip, create_app

    config = _config(preset, options)
    with socket.socket() as probe:  # one clear line, before loading the clip
        try:
            probe.bind(("127.0.0.1", port))
        except OSError:
            raise UnjelloError(f"port {port} is in use on 127.0.0.1; give another with "
                               "--port") from None
    if not input.exists():
        raise UnjelloError(f"{input}: no such file or folder")
    click.echo(f"reading {input} ...", err=True)
    with PreviewClip(input, config, max_frames) as clip:
        url = f"http://127.0.0.1:{port}/"
        click.echo(f"preview of {input} ({clip.count} frames) at {url}; Ctrl+C stops it",
                   err=True)
        if not no_browser:
            threading.Timer(1.0, webbrowser.open, [url]).start()
        uvicorn.run(create_app(clip), host="127.0.0.1", port=port, log_level="warning")


@cli.command()
@click.argument("source", type=click.Path(path_type=Path))
@click.option("-o", "--output", type=click.Path(path_type=Path), required=True,
              help="Rolling-shutter clip to write (.mp4 or a folder).")
@click.option("--truth", type=click.Path(path_type=Path), required=True,
              help="Global-shutter truth to write (.mp4 or a folder).")
@click.option("--truth-motion", type=click.Path(path_type=Path),
              help="True trajectory JSON (default <truth>.motion.json).")
@click.option("--motion", default="pan", show_default=True,
              help="pan, stop, diagonal, shake, jello, whip (still, then --speed), or a "
                   "JSON trajectory file.")
@_timing_options
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
             readout: str, direction: str, reference: str, frames: int, fps: float | None,
             size: str | None, speed: float, amplitude: float, exposure: float, crf: int,
             gyro_out: Path | None, overwrite: bool) -> None:
    """Render a rolling-shutter clip and its truth from an image or a GS video."""
    from ..errors import SettingsError
    from ..simulate import simulate_clip

    wh = None
    if size:
        try:
            w, h = (int(v) for v in size.lower().split("x"))
            wh = (w, h)
        except ValueError:
            raise SettingsError(f"--size must look like 640x480, got {size!r}") from None
    timing = SensorTiming(parse_readout(readout, fps or 30.0), direction,  # type: ignore[arg-type]
                          reference)  # type: ignore[arg-type]
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
    from ..metrics import evaluate as run

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
@_config_options(per_clip=False)
@click.option("--executor", "kind", type=click.Choice(["local", "dask", "ray"]),
              default="local", show_default=True,
              help="Local process pool, or an existing/local Dask or Ray cluster.")
@click.option("--address", help="Dask scheduler or Ray cluster address (default: local).")
@click.option("--workers", type=click.IntRange(1, 4096), help="Local workers (default: cores).")
@click.option("--report", type=click.Path(path_type=Path),
              help="JSON-lines report (default OUT_DIR/unjello-batch.jsonl).")
@click.option("-y", "--overwrite", is_flag=True, help="Redo clips whose output exists.")
@click.option("-q", "--quiet", is_flag=True)
def batch(inputs: tuple[str, ...], out_dir: Path, preset: str | None, kind: str,
          address: str | None, workers: int | None, report: Path | None, overwrite: bool,
          quiet: bool, **options: Any) -> None:
    """Correct many clips (files, folders, globs) into OUT_DIR; resumable."""
    from ..run.batch import run_batch

    config = _config(preset, options)

    def show(row: dict) -> None:
        if not quiet:
            extra = f" ({_flagify(row['error'])})" if row["error"] else ""
            click.echo(f"{row['status']:8} {row['input']} {row['seconds']:.1f} s{extra}",
                       err=True)

    rows = run_batch(inputs, out_dir, kind=kind, address=address, workers=workers,
                     overwrite=overwrite, report=report, config=config, on_result=show)
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
    from ..exports.outputs import plot_trajectory
    from ..io.sink import check_new
    from ..trajectory import Trajectory

    check_new(output, overwrite)
    plot_trajectory(Trajectory.load(motion), output)
    click.echo(f"wrote {output}", err=True)


@cli.command()
@click.argument("input", type=click.Path(path_type=Path))
@click.option("--estimate", is_flag=True, help="Also estimate the readout and the lens from "
              "the footage (its first 60 frames), as estimate-readout does.")
@click.option("--json", "as_json", is_flag=True)
def probe(input: Path, estimate: bool, as_json: bool) -> None:
    """Describe a video or a folder of frames, and the readout and lens correct would use."""
    from ..clip import describe

    doc = describe(input)
    est = None
    if estimate:
        from ..readout.footage import estimate_readout_file, lens_flags

        est = estimate_readout_file(input, direction=doc["direction"])
        doc["estimate"] = est.as_json(costs=False)
    if as_json:
        click.echo(json.dumps(doc))
        return
    d = doc
    if d["folder"]:
        click.echo(f"{input}: a folder of {d['frames']} {d['format'].upper()} frames, "
                   f"{d['width']}x{d['height']}, {d['channels']} channel(s), "
                   f"{d['bit_depth']}-bit; no frame rate of its own ({d['assumed_fps']:g} "
                   "fps unless --fps)")
    else:
        click.echo(f"{input}: {d['width']}x{d['height']} {d['codec']} {d['pix_fmt']} "
                   f"({d['bit_depth']}-bit), {d['fps']:.3f} fps"
                   f"{' (variable)' if d['variable_frame_rate'] else ''}, {d['frames']} "
                   f"frames, {d['duration']:.2f} s")
        click.echo(f"rotation {d['rotation']} deg, {d['audio_streams']} audio stream(s)")
    if d["readout"] is not None:
        click.echo(f"readout: {d['readout_ms']:.4g} ms ({d['readout']:.4g} of the frame "
                   f"interval, {d['direction']}), from the {d['readout_source']}")
    else:
        click.echo("readout: not stated by the file, a sidecar or the camera database; "
                   "measure it (unjello readout), estimate it (unjello estimate-readout) or "
                   "pass --readout")
    for line in d["warnings"]:
        click.echo(_flagify(line))
    if d["lens"]:
        click.echo(f"lens: focal {d['lens']['focal']:.0f} px, fisheye k "
                   + ", ".join(f"{v:.3g}" for v in d["lens"]["distortion"]))
    if est is not None:
        click.echo(f"from the footage: {est.describe()}")
        if est.lens is not None and est.reliable:
            click.echo(f"  its lens, fitted to the motion: {lens_flags(est.lens)}")


for _command in (readout, estimate_readout, cameras, export_gyroflow):
    cli.add_command(_command)


def _reader_gone() -> None:
    """Say that standard output's reader stopped early (``| head``); exit 1, quietly."""
    # Python would complain again flushing the closed pipe at exit.
    os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    click.echo("unjello: the program reading the output stopped (broken pipe)", err=True)
    sys.exit(1)


class _Stopped(KeyboardInterrupt):
    """SIGTERM or SIGHUP, raised as Ctrl-C's KeyboardInterrupt is (the same cleanup)."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


def _stop(signum: int, frame: object) -> None:
    raise _Stopped(signum)


def _catch_stop_signals() -> None:
    """Let ``kill`` (SIGTERM) and a closed terminal (SIGHUP) clean up as Ctrl-C does.

    A signal ignored on entry (``nohup``) stays ignored; so does SIGINT in a job that
    its shell started in the background (POSIX shells start those with SIGINT ignored).
    """
    for name in ("SIGTERM", "SIGHUP"):
        sig = getattr(signal, name, None)
        if sig is not None and signal.getsignal(sig) != signal.SIG_IGN:
            try:
                signal.signal(sig, _stop)
            except ValueError:  # not the main thread: the caller's own business
                return


def _interrupted(exc: BaseException | None) -> None:
    """Say that the run was stopped, and exit 128 + the signal (130 for Ctrl-C)."""
    signum = exc.signum if isinstance(exc, _Stopped) else signal.SIGINT
    how = "interrupted" if signum == signal.SIGINT else f"stopped ({signal.Signals(signum).name})"
    click.echo(f"{how}; partial output removed", err=True)
    sys.exit(128 + int(signum))


def main(argv: list[str] | None = None) -> Any:
    """Entry point: run the CLI; Ctrl-C is one line and exit code 130 (SIGTERM: 143)."""
    _catch_stop_signals()
    # What is imported by now lives as long as the process: kept out of the cyclic
    # collector, whose full passes (and the one at exit, 0.2-0.3 s) would walk it again.
    gc.freeze()
    try:
        code = cli.main(args=argv, prog_name="unjello", standalone_mode=False)
    except click.exceptions.Abort as exc:  # Click's word for a KeyboardInterrupt
        _interrupted(exc.__cause__)
    except KeyboardInterrupt as exc:
        _interrupted(exc)
    except click.exceptions.ClickException as exc:
        exc.show()
        sys.exit(exc.exit_code)
    if isinstance(code, int) and code:
        sys.exit(code)
    return code
