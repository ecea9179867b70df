"""Files beside a clip, and what a clip's own metadata states.

* The readout a sidecar or the file states (:func:`stated_readout`).
* Gyro logs: finding a clip's own (``NAME.gyro.csv``, :func:`find_gyro_log`), reading
  (:func:`read_gyro`) and writing (:func:`write_gyro`) them. The gyro method
  (:mod:`unjello.motion.gyro.method`) takes the samples as arrays and touches no files.
"""

from __future__ import annotations

import json
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError, SettingsError
from ..gyrolog import GyroConfig, GyroLog
from .gcsv import is_gcsv, read_gcsv, written_by_unjello
from .telemetry import EmbeddedGyro, embedded_gyro, telemetry_available, vendor_call

__all__ = ["StatedReadout", "stated_readout", "LensProfile", "read_lens_profile",
           "find_gyro_log", "gyro_source", "read_gyro", "write_gyro"]


@dataclass(frozen=True)
class StatedReadout:
    """A readout time stated by the file or a sidecar.

    Attributes
    ----------
    milliseconds : float
    source : str
        Where it was found (for the user).
    """

    milliseconds: float
    source: str


def _find_readout_key(obj: object, depth: int = 0) -> float | None:
    """First numeric value under a key naming the readout time (ms), in nested data."""
    if depth > 6:
        return None
    if isinstance(obj, dict):
        for k, v in obj.items():
            key = str(k).lower().replace(" ", "_")
            if "readout" in key and not isinstance(v, (dict, list)):
                try:
                    value = float(str(v).lower().replace("ms", "").strip())
                except ValueError:
                    continue
                if "us" in key or "micro" in key:
                    value /= 1000.0
                if value > 0:
                    return value
        for v in obj.values():
            found = _find_readout_key(v, depth + 1)
            if found is not None:
                return found
    elif isinstance(obj, list):
        for v in obj[:50]:
            found = _find_readout_key(v, depth + 1)
            if found is not None:
                return found
    return None


def stated_readout(path: str | os.PathLike) -> StatedReadout | None:
    """Readout time stated for a video by a sidecar file or its metadata, if any.

    Looked up, in order:

    1. A JSON sidecar beside the video -- ``NAME.readout.json``, ``NAME.json`` or
       ``STEM.json`` -- with a key naming the readout in ms, such as Gyroflow's
       ``frame_readout_time`` (lens profiles and project files) or ``readout_ms``.
    2. Container and stream metadata tags whose name contains ``readout`` (ms).
    3. With the optional ``telemetry-parser`` package (``pip install 'unjello[gyro]'``),
       the camera metadata it decodes (Sony, GoPro, DJI, ...), searched the same way.

    Parameters
    ----------
    path : path-like
        The video (or frame folder: sidecars only).

    Returns
    -------
    StatedReadout or None
    """
    p = Path(path)
    for side in (p.with_name(p.name + ".readout.json"), p.with_name(p.name + ".json"),
                 p.with_suffix(".json")):
        if side != p and side.is_file():
            try:
                value = _find_readout_key(json.loads(side.read_text()))
            except (OSError, ValueError):
                value = None
            if value is not None:
                return StatedReadout(value, f"sidecar {side.name}")
    if not p.is_file():
        return None
    from .video import metadata_tags

    value = _find_readout_key(metadata_tags(p))
    if value is not None:
        return StatedReadout(value, "container metadata")
    try:
        import telemetry_parser
    except ImportError:
        return None
    tp = vendor_call(lambda: telemetry_parser.Parser(str(p)), None)
    if tp is None:
        return None
    # (structured: the human-readable form writes nested metadata as one string)
    value = _find_readout_key(vendor_call(lambda: tp.telemetry(human_readable=False), None))
    if value is not None:
        return StatedReadout(value, f"camera metadata ({tp.camera} {tp.model})")
    return None


@dataclass(frozen=True)
class LensProfile:
    """What a Gyroflow lens profile (JSON) given by the user states.

    Attributes
    ----------
    name : str
        The file's name.
    readout : StatedReadout or None
        Its ``frame_readout_time``.
    focal, width : float or None
        The fisheye camera matrix's focal length, at the calibrated width.
    k : tuple of float or None
        The four fisheye distortion coefficients.
    """

    name: str
    readout: StatedReadout | None
    focal: float | None = None
    width: float | None = None
    k: tuple[float, ...] | None = None

    def lens(self, width: int) -> tuple[float, tuple[float, ...]] | None:
        """Return the focal length at ``width`` px and ``k``, if the profile states both."""
        if self.focal is None or self.k is None:
            return None
        return self.focal * (width / self.width if self.width else 1.0), self.k


def read_lens_profile(path: str | os.PathLike) -> LensProfile:
    """Read a Gyroflow lens profile: its readout, focal length and fisheye distortion.

    Raises
    ------
    SettingsError
        If it cannot be read or is not JSON.
    """
    p = Path(path)
    try:
        doc = json.loads(p.read_text())
    except OSError as exc:
        raise SettingsError(f"{p}: cannot read the lens profile "
                            f"({exc.strerror or exc})") from None
    except ValueError:
        raise SettingsError(f"{p}: not a lens profile (not JSON)") from None
    value = _find_readout_key(doc)
    readout = None if value is None else StatedReadout(value, f"lens profile {p.name}")
    if not isinstance(doc, dict):
        return LensProfile(p.name, readout)
    fisheye = doc.get("fisheye_params") or {}
    try:
        fx = float(fisheye["camera_matrix"][0][0])
        k = tuple(float(v) for v in fisheye["distortion_coeffs"])
        width = (doc.get("calib_dimension") or {}).get("w")
        calib_w = float(width) if width else None
    except (KeyError, TypeError, ValueError, IndexError):
        return LensProfile(p.name, readout)
    if len(k) != 4 or not fx > 0:
        return LensProfile(p.name, readout)
    return LensProfile(p.name, readout, fx, calib_w, k)


def find_gyro_log(src: str | os.PathLike) -> Path:
    """Return the gyro log beside a clip: ``NAME.gyro.csv``, ``.gyro.txt``, or unjello's ``.gcsv``.

    This is how the gyro method finds a clip's log when none is given (and how a batch
    finds each clip's).

    Raises
    ------
    SettingsError
        If there is none.
    """
    src = Path(src)
    base = src.with_suffix("") if src.is_file() else src
    for ext in (".gyro.csv", ".gyro.txt", ".gcsv"):
        cand = base.with_name(base.name + ext)
        # Another's NAME.gcsv is the camera's record, read by telemetry-parser
        # (gyro_source); one unjello wrote is a log with its calibration stated.
        if cand.is_file() and (ext != ".gcsv" or written_by_unjello(cand)):
            return cand
    raise SettingsError(f"the gyro method needs a gyro log: pass gyro=FILE or put "
                        f"{base.name}.gyro.csv beside {src.name}")


def gyro_source(src: str | os.PathLike, config: GyroConfig
                ) -> tuple[GyroLog, str, EmbeddedGyro | None]:
    """Return the gyro samples for a clip, where they came from (one line), and whose.

    In order: the log given (``config.path``), a log beside the clip
    (:func:`find_gyro_log`), the gyro the camera wrote into the file itself
    (:func:`~unjello.io.telemetry.embedded_gyro`).

    Returns
    -------
    log : GyroLog
    said : str
        Where the samples came from.
    own : EmbeddedGyro or None
        The camera's own gyro, when that is what was found (it says whether the camera
        stabilised the picture itself); None for a log.

    Raises
    ------
    SettingsError
        If there is none of them.
    """
    if config.path:
        return read_gyro(config.path, config.layout, config.units), \
            f"gyro log {Path(config.path).name}", None
    try:
        path = find_gyro_log(src)
    except SettingsError as missing:
        src_p = Path(src)
        found = embedded_gyro(src_p) if src_p.is_file() else None
        if found is None:
            reader = ("telemetry-parser can read" if telemetry_available() else
                      "could be read: telemetry-parser is not installed")
            raise SettingsError(f"{missing}; {src_p.name} has no gyro of its own that "
                                f"{reader}") from None
        return found.log, found.describe(), found
    return read_gyro(path, config.layout, config.units), f"gyro log {path.name}", None


def read_gyro(path: str | Path, layout: str = "auto", units: str = "rad") -> GyroLog:
    """Read a text or CSV gyro log: one sample per line, a time and three rates.

    Columns may be separated by commas, semicolons, tabs or spaces; lines that are not
    numbers (a header, ``#`` comments) are skipped. A Gyroflow ``.gcsv`` log is read by
    its header (:func:`unjello.io.gcsv.read_gcsv`; ``layout`` and ``units`` are ignored).

    Parameters
    ----------
    path : path-like
        The log.
    layout : str
        The first four columns' meaning, e.g. ``"t,x,y,z"`` or ``"x,y,z,t"``; ``"auto"``
        takes the one strictly increasing column of the first four as the time and the
        others, in order, as x, y, z.
    units : {'rad', 'deg'}
        Unit of the rates (per second).

    Returns
    -------
    GyroLog
        The time unit is read off the sampling interval: seconds below 50 ms, then
        milliseconds, microseconds, nanoseconds (IMUs sample at 100 Hz - 8 kHz).

    Raises
    ------
    InputError
        Not a readable log of four numeric columns.
    """
    p = Path(path)
    if is_gcsv(p):  # Gyroflow's own format: its header states units and layout
        return read_gcsv(p)[0]
    try:
        text = p.read_text(errors="replace")
    except OSError as exc:
        raise InputError(f"{p}: cannot read the gyro log ({exc.strerror or exc})") from None
    rows = []
    for line in text.splitlines():
        parts = [v for v in re.split(r"[,;\s]+", line.strip()) if v]
        try:
            vals = [float(v) for v in parts[:4]]
        except ValueError:
            continue
        if len(vals) == 4:
            rows.append(vals)
    if len(rows) < 10:
        raise InputError(f"{p}: not a gyro log (need lines of a time and three angular "
                         f"rates; found {len(rows)})")
    data = np.asarray(rows)
    if layout == "auto":
        rising = [i for i in range(4) if np.all(np.diff(data[:, i]) > 0)]
        if not rising:
            raise InputError(f"{p}: no column of increasing times; give the layout "
                             "(e.g. gyro_layout=t,x,y,z)")
        names = ["x", "y", "z"]
        order = {rising[0]: "t"}
        order.update({i: names.pop(0) for i in range(4) if i != rising[0]})
        cols = [order[i] for i in range(4)]
    else:
        cols = [c.strip().lower() for c in layout.split(",")]
        if sorted(cols) != ["t", "x", "y", "z"]:
            raise SettingsError(f"gyro layout must name t, x, y and z once each, got {layout!r}")
    t = data[:, cols.index("t")]
    rate = data[:, [cols.index(a) for a in "xyz"]]
    if units not in ("rad", "deg"):
        raise SettingsError(f"gyro units must be 'rad' or 'deg', got {units!r}")
    if units == "deg":
        rate = np.deg2rad(rate)
    dt = float(np.median(np.diff(t)))
    if dt <= 0:
        raise InputError(f"{p}: gyro sample times must increase")
    scale = next(s for limit, s in ((0.05, 1.0), (50.0, 1e-3), (5e4, 1e-6), (np.inf, 1e-9))
                 if dt < limit)
    return GyroLog(t * scale, rate)


def write_gyro(path: str | Path, time: np.ndarray, rate: np.ndarray) -> None:
    """Write a log :func:`read_gyro` reads: CSV with a ``t,x,y,z`` header, seconds, rad/s."""
    np.savetxt(path, np.column_stack([time, rate]), delimiter=",", fmt="%.9g",
               header="t,x,y,z", comments="")
