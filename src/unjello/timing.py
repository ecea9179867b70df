"""Sensor timing: when each scanline of a rolling-shutter frame is imaged.

This module is the single place for the time and geometry conventions of unjello.

Conventions
-----------
* Pixel coordinates: ``x`` to the right, ``y`` down; arrays are ``(row, col[, channel])``.
* Time unit: the (nominal) frame interval ``T``; frame ``n`` of a constant-rate clip
  starts at ``t = n``. With variable frame rate, frame ``n`` starts at its real
  timestamp divided by the nominal interval.
* Readout ratio ``rho`` = readout time / ``T``, ``0 < rho <= 1``. The paper
  (Liang, Chang & Chen 2008, Sec. IV) takes ``rho = 1``: one scanline per time unit
  and ``T`` equal to the number of lines. Here scanline ``r`` (``0 <= r < h``) of a
  frame starting at ``t_n`` is imaged at ``t = t_n + rho * r / h``.
* Reference time: the middle scanline ``r = (h - 1) / 2`` (the paper's eq. 11 and 26)
  or the first scanline ``r = 0``.
* Motion sign: a *displacement* ``D(t)`` is the image position of a static scene point
  at time ``t`` minus its position at some origin; a *velocity* ``v = dD/dt`` is in
  pixels per frame interval. Block-matching vectors follow the same sign: the vector
  of a block in frame ``n`` is its position in frame ``n`` minus the position of its
  match in frame ``n - 1`` (content moving right gives ``+x``).
* Scan direction: frames are turned once so that the core always sees top-to-bottom
  readout (:func:`to_top_bottom`) and turned back on output (:func:`from_top_bottom`).

Examples
--------
>>> t = SensorTiming(readout=0.5)
>>> t.row_times(4, start=2.0).tolist()
[2.0, 2.125, 2.25, 2.375]
>>> parse_readout("15.7ms", fps=30.0)
0.471
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt

from .errors import SettingsError

__all__ = [
    "Direction",
    "Reference",
    "DIRECTIONS",
    "REFERENCES",
    "SensorTiming",
    "parse_readout",
    "readout_request",
    "Milliseconds",
    "ReadoutRequest",
    "pixel_grid",
    "to_top_bottom",
    "from_top_bottom",
    "coded_axes",
    "scanline_displacement",
]

Direction = Literal["top-bottom", "bottom-top", "left-right", "right-left"]
Reference = Literal["middle", "first"]
DIRECTIONS: tuple[str, ...] = ("top-bottom", "bottom-top", "left-right", "right-left")
REFERENCES: tuple[str, ...] = ("middle", "first")


@dataclass(frozen=True)
class SensorTiming:
    """Readout ratio, scan direction and reference scanline of a rolling-shutter camera.

    Parameters
    ----------
    readout : float
        Readout time as a fraction of the frame interval, ``0 < readout <= 1``.
    direction : {'top-bottom', 'bottom-top', 'left-right', 'right-left'}
        Order in which the sensor reads its lines, in coded orientation.
    reference : {'middle', 'first'}
        Scanline whose time the corrected frame represents.
    """

    readout: float = 1.0
    direction: Direction = "top-bottom"
    reference: Reference = "middle"

    def __post_init__(self) -> None:
        if not (0.0 < float(self.readout) <= 1.0) or not np.isfinite(self.readout):
            raise SettingsError(
                f"readout must be in (0, 1] of the frame interval, got {self.readout!r}"
            )
        if self.direction not in DIRECTIONS:
            raise SettingsError(
                f"direction must be one of {', '.join(DIRECTIONS)}, got {self.direction!r}"
            )
        if self.reference not in REFERENCES:
            raise SettingsError(
                f"reference must be one of {', '.join(REFERENCES)}, got {self.reference!r}"
            )

    def row_times(self, height: int, start: float = 0.0) -> np.ndarray:
        """Return the imaging time of every scanline of a frame.

        Parameters
        ----------
        height : int
            Number of scanlines ``h`` (in top-bottom orientation).
        start : float
            Start time ``t_n`` of the frame, in frame intervals.

        Returns
        -------
        ndarray of shape (height,)
            ``t_n + readout * r / h`` for ``r = 0 .. h-1``.
        """
        return start + self.readout * np.arange(height, dtype=np.float64) / height

    def reference_row(self, height: int) -> float:
        """Return the (possibly fractional) row index of the reference scanline."""
        return (height - 1) / 2.0 if self.reference == "middle" else 0.0

    def reference_time(self, height: int, start: float = 0.0) -> float:
        """Return the time the corrected frame represents (eq. 11 and 26 for 'middle')."""
        return start + self.readout * self.reference_row(height) / height


_MS = re.compile(r"^\s*([-+]?[0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*ms\s*$", re.IGNORECASE)


@dataclass(frozen=True)
class Milliseconds:
    """A readout time in milliseconds, a fraction of the frame interval once the rate is known.

    Examples
    --------
    >>> Milliseconds(36.0).ratio(25.0)
    0.9
    """

    value: float

    def __post_init__(self) -> None:
        if not (np.isfinite(self.value) and self.value > 0):
            raise SettingsError(f"readout {self.value:g} ms must be a positive time")

    def ratio(self, fps: float) -> float:
        """Return the readout as a fraction of the frame interval at ``fps``.

        Raises
        ------
        SettingsError
            If that fraction is outside ``(0, 1]``.
        """
        value = round(self.value * 1e-3 * float(fps), 6)
        if not 0.0 < value <= 1.0:
            raise SettingsError(
                f"readout {self.value:g} ms is {value:.3f} of the frame interval at "
                f"{fps:g} fps, outside (0, 1]")
        return value

    def __str__(self) -> str:
        return f"{self.value:g}ms"


#: What a user may ask for as a readout: a fraction, a time, or ``"auto"``.
ReadoutRequest = float | Milliseconds | Literal["auto"]


def readout_request(value: float | str | Milliseconds) -> ReadoutRequest:
    """Parse a readout as a user gives it, once: a fraction, ``"15.7ms"`` or ``"auto"``.

    Parameters
    ----------
    value : float, str or Milliseconds
        ``0.9`` or ``"0.9"`` (fraction of the frame interval), ``"15.7ms"``, or
        ``"auto"`` (case-insensitive).

    Returns
    -------
    float, Milliseconds or 'auto'
        A fraction is checked to lie in ``(0, 1]``; a time to be positive (it becomes a
        fraction with the clip's frame rate, :meth:`Milliseconds.ratio`).

    Raises
    ------
    SettingsError
        If the value is none of these.

    Examples
    --------
    >>> readout_request("36ms"), readout_request(" AUTO "), readout_request("0.9")
    (Milliseconds(value=36.0), 'auto', 0.9)
    """
    if isinstance(value, Milliseconds):
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise SettingsError(f"readout must be a number, a time like 15.7ms or 'auto', "
                            f"not {value!r}")
    if isinstance(value, str):
        text = value.strip()
        if text.lower() == "auto":
            return "auto"
        m = _MS.match(text)
        if m:
            return Milliseconds(float(m.group(1)))
        try:
            number = float(text)
        except ValueError:
            raise SettingsError(f"cannot parse readout {value!r}: give a fraction like 0.9, "
                                "a time like 15.7ms, or auto") from None
    else:
        number = float(value)
    if not (np.isfinite(number) and 0.0 < number <= 1.0):
        raise SettingsError(f"readout {value!r} is outside (0, 1] of the frame interval "
                            "(a time needs 'ms', e.g. 15.7ms)")
    return number


def parse_readout(text: str | float, fps: float | None = None) -> float:
    """Return a readout given as a fraction or in milliseconds as a fraction in ``(0, 1]``.

    Parameters
    ----------
    text : str or float
        ``"0.9"`` (fraction of the frame interval) or ``"15.7ms"``.
    fps : float, optional
        Nominal frame rate, needed to turn milliseconds into a fraction.

    Raises
    ------
    SettingsError
        If the value cannot be parsed, is ``"auto"``, or is outside ``(0, 1]``.
    """
    req = readout_request(text)
    if req == "auto":
        raise SettingsError("readout 'auto' is decided from the clip "
                            "(unjello.clip.resolve_timing), not parsed")
    if isinstance(req, Milliseconds):
        if not fps:
            raise SettingsError("a readout in milliseconds needs the clip's frame rate")
        return req.ratio(fps)
    return float(req)


def to_top_bottom(image: np.ndarray, direction: str) -> np.ndarray:
    """Turn an image in coded orientation so that its scanlines are read top to bottom.

    Parameters
    ----------
    image : ndarray of shape (H, W[, C])
        Image in coded (sensor) orientation.
    direction : str
        Scan direction of the sensor.

    Returns
    -------
    ndarray
        A contiguous array whose row 0 is the first line read out.

    Examples
    --------
    >>> a = np.arange(6).reshape(2, 3)
    >>> to_top_bottom(a, "left-right").tolist()
    [[0, 3], [1, 4], [2, 5]]
    >>> bool((from_top_bottom(to_top_bottom(a, "right-left"), "right-left") == a).all())
    True
    """
    if direction == "top-bottom":
        return image
    if direction == "bottom-top":
        out = image[::-1]
    elif direction == "left-right":
        out = np.swapaxes(image, 0, 1)
    elif direction == "right-left":
        out = np.swapaxes(image, 0, 1)[::-1]
    else:
        raise SettingsError(f"unknown direction {direction!r}")
    return np.ascontiguousarray(out)


def coded_axes(direction: str) -> np.ndarray:
    """Return ``B`` with ``w_coded = B w_top_bottom`` for angular rates (camera axes).

    :func:`unjello.timing.to_top_bottom` turns the coded frame by ``A`` (point ``q_t = A
    q_c``, centred pixel coordinates); a rate is a pseudovector, ``w_t = det(A) A w_c``,
    so ``B = det(A) A^T``.
    """
    a = {"top-bottom": np.eye(3),
         "bottom-top": np.diag([1.0, -1.0, 1.0]),
         "left-right": np.array([[0.0, 1, 0], [1, 0, 0], [0, 0, 1]]),
         "right-left": np.array([[0.0, 1, 0], [-1, 0, 0], [0, 0, 1]])}.get(direction)
    if a is None:
        raise SettingsError(f"unknown direction {direction!r}")
    return float(np.linalg.det(a)) * a.T


def from_top_bottom(image: np.ndarray, direction: str) -> np.ndarray:
    """Undo :func:`to_top_bottom`."""
    if direction == "top-bottom":
        return image
    if direction == "bottom-top":
        out = image[::-1]
    elif direction == "left-right":
        out = np.swapaxes(image, 0, 1)
    elif direction == "right-left":
        out = np.swapaxes(image[::-1], 0, 1)
    else:
        raise SettingsError(f"unknown direction {direction!r}")
    return np.ascontiguousarray(out)


def pixel_grid(height: int, width: int, top: int = 0, left: int = 0
               ) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.float32]]:
    """Column and row coordinates (float32, broadcast views) of a ``height x width`` block.

    ``top`` and ``left`` offset them (a crop of a larger frame).
    """
    gx = np.broadcast_to(np.arange(left, left + width, dtype=np.float32)[None, :],
                         (height, width))
    gy = np.broadcast_to(np.arange(top, top + height, dtype=np.float32)[:, None],
                         (height, width))
    return gx, gy


@dataclass(frozen=True)
class ClipTime:
    """A point or a length of a clip, in seconds or in frames (``--start``, ``--duration``).

    Attributes
    ----------
    value : float
        How many seconds, or frames.
    unit : {'s', 'f'}
        Seconds (as ffmpeg's ``-ss``/``-t``) or frames.
    """

    value: float
    unit: Literal["s", "f"] = "s"

    def __str__(self) -> str:
        return f"{self.value:g}{'s' if self.unit == 's' else 'f'}"

    def frames(self, fps: float) -> float:
        """Return the time in frames at ``fps``."""
        return self.value if self.unit == "f" else self.value * fps

    def seconds(self, fps: float) -> float:
        """Return the time in seconds at ``fps``."""
        return self.value if self.unit == "s" else self.value / fps


_CLOCK = re.compile(r"^(?:(\d+):)?(\d+):(\d+(?:\.\d*)?)$")


def clip_time(value: float | str | ClipTime | None) -> ClipTime | None:
    """Read a time of a clip: seconds (``12.5``, ``12.5s``, ``1:02.5``) or frames (``150f``).

    Examples
    --------
    >>> clip_time("1:02.5"), clip_time("150f")
    (ClipTime(value=62.5, unit='s'), ClipTime(value=150.0, unit='f'))

    Raises
    ------
    SettingsError
        Anything else, or a negative time.
    """
    if value is None or isinstance(value, ClipTime):
        return value
    text = str(value).strip().lower()
    clock = _CLOCK.match(text)
    try:
        if clock:
            h, m, s = clock.groups()
            out = ClipTime(int(h or 0) * 3600 + int(m) * 60 + float(s))
        elif re.fullmatch(r"[\d.]+\s*(f|frames?)", text):
            out = ClipTime(float(re.sub(r"\s*(f|frames?)$", "", text)), "f")
        else:
            out = ClipTime(float(text.removesuffix("s").strip()))
    except ValueError:
        raise SettingsError(f"{value!r} is not a time of the clip: give seconds (12.5, "
                            "1:02.5) or frames (150f)") from None
    if not (out.value >= 0 and np.isfinite(out.value)):
        raise SettingsError(f"a time of the clip cannot be negative, got {value!r}")
    return out


@dataclass(frozen=True)
class ClipSpan:
    """The part of a clip to correct: from ``start`` for ``duration`` (None: all of it).

    Its motion is still measured from the frames around it (:mod:`unjello.io.source`).
    """

    start: ClipTime | None = None
    duration: ClipTime | None = None

    def __post_init__(self) -> None:
        if self.duration is not None and self.duration.value <= 0:
            raise SettingsError("duration must be more than 0")

    @property
    def whole(self) -> bool:
        """Whether it is the whole clip."""
        return (self.start is None or self.start.value == 0) and self.duration is None

    def first_frame(self, fps: float) -> int:
        """Return the index of the part's first frame at ``fps``."""
        return round(self.start.frames(fps)) if self.start is not None else 0

    def length(self, fps: float, frames: float = float("inf")) -> float:
        """Return how many frames the part holds of a clip of ``frames`` (inf: unknown)."""
        rest = max(0.0, frames - self.first_frame(fps))
        return min(round(self.duration.frames(fps)), rest) if self.duration is not None else rest


def scanline_displacement(velocity: np.ndarray, timing: SensorTiming) -> np.ndarray:
    """Integrate per-scanline velocity from the reference time (eq. 26).

    Parameters
    ----------
    velocity : ndarray of shape (h, 2)
        ``v'(t_r)`` for every scanline ``r``, px per frame interval.
    timing : SensorTiming
        Readout ratio and reference scanline.

    Returns
    -------
    ndarray of shape (h, 2)
        ``Delta(r) = integral from t_ref to t_r of v'(t) dt`` (trapezoid rule on the
        scanline grid, whose step is ``rho / h``).

    Examples
    --------
    A constant velocity of 3 px per frame with a full readout moves the last of 5 rows
    by ``3 * 2/5`` relative to the middle row:

    >>> d = scanline_displacement(np.tile([3.0, 0.0], (5, 1)), SensorTiming(1.0))
    >>> np.round(d[:, 0], 3).tolist()
    [-1.2, -0.6, 0.0, 0.6, 1.2]
    """
    v = np.asarray(velocity, dtype=np.float64)
    h = v.shape[0]
    dt = timing.readout / h
    cum = np.zeros_like(v)
    if h > 1:
        cum[1:] = np.cumsum(0.5 * (v[1:] + v[:-1]) * dt, axis=0)
    ref = timing.reference_row(h)
    rows = np.arange(h, dtype=np.float64)
    at_ref = np.array([np.interp(ref, rows, cum[:, k]) for k in range(2)])
    return cum - at_ref
