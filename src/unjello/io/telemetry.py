"""The gyroscope a camera wrote into its own video file, read by ``telemetry-parser``.

Action cameras, drones and many mirrorless bodies record their IMU beside the picture:
GoPro (GPMF), Sony (rtmd), DJI, Insta360, Blackmagic and others. The ``telemetry-parser``
package (the Gyroflow project's reader) decodes them all and gives the samples in one
form: times in ms on the video's clock and angular rates in degrees per second, in the
camera's own axes. This module turns them into a :class:`~unjello.gyrolog.GyroLog`
(seconds, rad/s) for the gyro method; which gyro axes are the camera's x, y and z, the
clock offset and the focal length are still found from the footage
(:func:`unjello.motion.gyro.method.calibrate`) unless they are given.
"""

from __future__ import annotations

import importlib.util
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

import numpy as np

from ..errors import InputError
from ..gyrolog import GyroLog
from ..readout.cameras import camera_name

__all__ = ["EmbeddedGyro", "embedded_gyro", "telemetry_available", "camera_of",
           "vendor_call"]

T = TypeVar("T")


def vendor_call(call: Callable[[], T], default: T) -> T:
    """Return ``call()``, or ``default`` when telemetry-parser fails on the file.

    Its vendor parsers raise anything on files they do not know, and a Rust panic comes
    out as pyo3's ``PanicException``, a BaseException that ``except Exception`` lets
    through; only an interrupt or an exit goes on up.
    """
    try:
        return call()
    except (KeyboardInterrupt, SystemExit):
        raise
    except BaseException:  # noqa: BLE001 - see above
        return default


def telemetry_available() -> bool:
    """Return whether ``telemetry-parser`` is installed (a default dependency on 3.11-3.12)."""
    return importlib.util.find_spec("telemetry_parser") is not None


@dataclass(frozen=True)
class EmbeddedGyro:
    """A camera's own gyro samples, read from its video file.

    Attributes
    ----------
    log : GyroLog
        The samples (seconds on the video's clock, rad/s).
    camera, model : str
        As ``telemetry-parser`` names them (e.g. ``GoPro``, ``HERO5 Black``).
    stabilised : str
        How the camera says it stabilised the picture itself (GoPro's ``EISA`` tag, e.g.
        ``HS HLevel`` for HyperSmooth with horizon levelling); empty when it did not.
        Such a picture no longer moves as the gyro says.
    """

    log: GyroLog
    camera: str
    model: str
    stabilised: str = ""

    @property
    def rate_hz(self) -> float:
        """Mean sampling rate."""
        t = self.log.time
        return float((t.size - 1) / (t[-1] - t[0]))

    def describe(self) -> str:
        """One line: whose gyro, how many samples."""
        name = camera_name(self.camera, self.model)
        return (f"the camera's own gyro ({name or 'unknown camera'}: {self.log.time.size:,} "
                f"samples at {self.rate_hz:.0f} Hz, read by telemetry-parser)")


def embedded_gyro(path: str | os.PathLike) -> EmbeddedGyro | None:
    """Return the gyro samples embedded in a video file, or None if it has none.

    Parameters
    ----------
    path : path-like
        The video file as the camera wrote it.

    Returns
    -------
    EmbeddedGyro or None
        None when ``telemetry-parser`` is not installed, does not know the file, or finds
        fewer than two gyro samples in it.

    Raises
    ------
    InputError
        When the samples are there but unusable (times not increasing after sorting out
        repeats).
    """
    try:
        import telemetry_parser
    except ImportError:
        return None
    parser = vendor_call(lambda: telemetry_parser.Parser(str(path)), None)
    samples = vendor_call(parser.normalized_imu, None) if parser is not None else None
    if parser is None or samples is None:
        return None
    rows = [(s["timestamp_ms"], *s["gyro"]) for s in samples or ()
            if s.get("gyro") is not None and s.get("timestamp_ms") is not None]
    if len(rows) < 2:
        return None
    data = np.asarray(rows, dtype=np.float64)
    data = data[np.argsort(data[:, 0], kind="stable")]
    keep = np.concatenate([[True], np.diff(data[:, 0]) > 0])  # repeated stamps: the first
    data = data[keep]
    if data.shape[0] < 2 or not np.isfinite(data).all():
        raise InputError(f"{path}: the embedded gyro samples are unusable")
    log = GyroLog(data[:, 0] / 1000.0, np.deg2rad(data[:, 1:4]))
    return EmbeddedGyro(log, str(parser.camera or "").strip(), str(parser.model or "").strip(),
                        _stabilised(parser))


# GoPro's GPMF keys, as telemetry-parser names the ones it has no name for: EISE (image
# stabilisation enabled, Y/N) and EISA (which: "N", "Y", "HS HLevel", ...).
_EISE, _EISA = "0x45495345", "0x45495341"


def _stabilised(parser: object) -> str:
    """Return the camera's own stabilisation setting, if its metadata says it was on."""
    groups = vendor_call(lambda: parser.telemetry(human_readable=True),  # type: ignore[attr-defined]
                         None)
    for group in groups or ():
        for tags in (group or {}).values():
            if not isinstance(tags, dict):
                continue
            mode = str(tags.get(_EISA, "")).strip()
            if mode and mode.upper() not in ("N", "NO", "OFF"):
                return mode
            if str(tags.get(_EISE, "")).strip().upper() == "Y":
                return "on"
    return ""


def camera_of(path: str | os.PathLike) -> str | None:
    """Return the camera a video file names (brand and model), if it names one.

    From the camera metadata ``telemetry-parser`` decodes (GoPro, Sony, DJI, ...), else
    the container's make and model tags (phones: ``com.apple.quicktime.make``/``model``,
    Android's ``make``/``model``).
    """
    p = Path(path)
    if not p.is_file():
        return None
    if telemetry_available():
        import telemetry_parser
        parser = vendor_call(lambda: telemetry_parser.Parser(str(p)), None)
        if parser is not None:
            name = camera_name(str(parser.camera or ""), str(parser.model or ""))
            if name:
                return name
    from .video import metadata_tags

    tags = {k.lower(): str(v).strip() for k, v in metadata_tags(p).items()}
    make = next((v for k, v in tags.items() if k.endswith("make") and v), "")
    model = next((v for k, v in tags.items() if k.endswith("model") and v), "")
    return camera_name(make, model) if model else None
