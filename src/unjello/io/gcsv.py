"""Gyroflow's ``.gcsv`` gyro logs: read, and what one unjello wrote says of itself.

A ``.gcsv`` starts ``GYROFLOW IMU LOG`` (or ``CAMERA IMU LOG``), then ``key,value``
lines (``tscale``: seconds per time unit, default 0.001; ``gscale``: rad/s per rate unit,
default 1; ``orientation``: Gyroflow's IMU axes from the columns), then a ``t,gx,gy,gz``
line and one sample a line (telemetry-parser's ``src/gyroflow/gcsv.rs``). One written by
:func:`unjello.exports.gyroflow.gcsv_text` (``vendor,unjello``) also states what the gyro method
would otherwise calibrate: its columns are the camera's axes in the coded frame, its time
0 is the clip's time ``unjello_start`` (s), its rates were taken through a lens of
``unjello_focal`` pixels, and with ``unjello_rates,steps`` each rate is the mean over the
step before its time (read at the step's middle).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..gyrolog import GyroLog, _axes_spec
from ..timing import coded_axes

__all__ = ["is_gcsv", "read_gcsv", "stated_calibration", "written_by_unjello"]

_MAGIC = ("GYROFLOW IMU LOG", "CAMERA IMU LOG")


def is_gcsv(path: str | os.PathLike) -> bool:
    """Return whether a file is a ``.gcsv`` log (by its first line)."""
    try:
        with open(path, "rb") as f:
            head = f.read(32)
    except OSError:
        return False
    return head.lstrip(b"\xef\xbb\xbf").startswith(tuple(m.encode() for m in _MAGIC))


def written_by_unjello(path: str | os.PathLike) -> bool:
    """Return whether a file is a ``.gcsv`` log :mod:`unjello.exports.gyroflow` wrote."""
    if not is_gcsv(path):
        return False
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            head = f.read(500)
    except OSError:
        return False
    return "\nvendor,unjello\n" in head


def read_gcsv(path: str | os.PathLike) -> tuple[GyroLog, dict[str, str]]:
    """Read a ``.gcsv`` log: its gyro samples (seconds, rad/s, the file's axes) and header.

    Raises
    ------
    InputError
        Not a log of at least two samples of a time and three rates.
    """
    p = Path(path)
    try:
        text = p.read_text(errors="replace")
    except OSError as exc:
        raise InputError(f"{p}: cannot read the gyro log ({exc.strerror or exc})") from None
    header: dict[str, str] = {}
    rows: list[list[float]] = []
    body = False
    for line in text.splitlines()[1:]:
        parts = [v.strip() for v in line.split(",")]
        if not body:
            if parts[0] in ("t", "time"):
                body = True
            elif len(parts) == 2:
                header[parts[0]] = parts[1]
            continue
        try:
            rows.append([float(v) for v in parts[:4]])
        except ValueError:
            continue
    data = np.asarray([r for r in rows if len(r) == 4])
    if data.shape[0] < 2:
        raise InputError(f"{p}: a .gcsv log without samples (need lines of a time and "
                         "three rates after the 't,gx,gy,gz' line)")
    try:
        tscale = float(header.get("tscale", "0.001"))
        gscale = float(header.get("gscale", "1"))
    except ValueError:
        raise InputError(f"{p}: its tscale or gscale is not a number") from None
    data = data[np.concatenate([[True], np.diff(data[:, 0]) > 0])]
    time = data[:, 0] * tscale
    if header.get("unjello_rates") == "steps":
        # Each rate is the mean over the step before its time: at the step's middle the
        # trapezoid rule of GyroLog integrates them exactly.
        time = time - 0.5 * float(np.median(np.diff(time)))
    return GyroLog(time, data[:, 1:4] * gscale), header


def stated_calibration(header: dict[str, str], direction: str) -> dict[str, float | str]:
    """Return what a log unjello wrote states of its axes, clock and lens; {} for another's.

    Parameters
    ----------
    header : dict
        From :func:`read_gcsv`.
    direction : str
        The clip's scan direction: the log's axes are the coded frame's, the gyro method
        works on the frame turned top to bottom.

    Returns
    -------
    dict
        :class:`~unjello.gyrolog.GyroConfig` fields: ``axes``, ``offset`` (s) and
        ``focal`` (px).
    """
    if header.get("vendor") != "unjello" or "unjello_focal" not in header:
        return {}
    turn = np.linalg.inv(coded_axes(direction))  # coded -> top-bottom
    try:
        return {"axes": _axes_spec(turn), "offset": -float(header.get("unjello_start", "0")),
                "focal": float(header["unjello_focal"])}
    except ValueError:
        return {}
