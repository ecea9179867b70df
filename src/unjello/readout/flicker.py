"""The readout time measured from a flicker frame.

A light flickering at a known frequency ``f`` (an LED driven at 1 kHz, mains lighting
at 100/120 Hz) is bright and dark in turn while the sensor reads its lines, so a frame
shows bands that repeat every ``1/f`` seconds of readout. Their period ``P`` in lines
gives the time per line ``1 / (f P)``, and the readout time of the ``h`` lines is
``h / (f P)`` (:func:`readout_from_flicker`). The period is found from the row profile
(mean over the lines' pixels, high-passed): the peak of its zero-padded spectrum, then
a least-squares sinusoid fit; blur, noise and partial coverage change the bands'
contrast, not their period.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ..errors import InputError
from ..timing import to_top_bottom

__all__ = ["FlickerReadout", "band_period", "readout_from_flicker"]


@dataclass(frozen=True)
class FlickerReadout:
    """Readout measured from a flicker frame.

    Attributes
    ----------
    milliseconds : float
        Readout time of all lines.
    period_lines : float
        Band period in lines.
    lines : int
        Number of lines of the frame.
    contrast : float
        Amplitude of the fitted bands relative to the profile's spread (0-1).
    """

    milliseconds: float
    period_lines: float
    lines: int
    contrast: float

    def ratio(self, fps: float) -> float:
        """Readout as a fraction of the frame interval at ``fps``."""
        return self.milliseconds * 1e-3 * fps


def band_period(image: np.ndarray, direction: str = "top-bottom") -> tuple[float, float]:
    """Period (in lines) of flicker bands across the lines of an image.

    Parameters
    ----------
    image : ndarray of shape (H, W[, C])
        The frame, in coded orientation.
    direction : str
        Scan direction: the bands run along the lines.

    Returns
    -------
    period : float
        Band period in lines.
    contrast : float
        Fitted sinusoid amplitude over the profile's standard deviation (about 1.4 for
        clean bands, near 0 when there are none).

    Raises
    ------
    InputError
        If no periodic banding is found.
    """
    from scipy.optimize import curve_fit  # imported on use: it is slow to import

    img = to_top_bottom(np.asarray(image), direction).astype(np.float64)
    if img.ndim == 3:
        img = img[..., :3].mean(axis=2)
    h = img.shape[0]
    if h < 16:
        raise InputError("image too small to measure flicker bands")
    profile = img.mean(axis=1)
    trend = cv2.GaussianBlur(profile[:, None], (1, 0), sigmaX=0, sigmaY=h / 6.0)[:, 0]
    x = profile - trend
    if not np.any(x):
        raise InputError("no flicker bands: the image has no brightness variation across lines")
    pad = 1 << int(np.ceil(np.log2(h * 32)))
    spec = np.abs(np.fft.rfft(x * np.hanning(h), n=pad))
    freqs = np.fft.rfftfreq(pad)  # cycles per line
    band = (freqs >= 1.5 / h) & (freqs <= 0.5)
    if not band.any():
        raise InputError("image too small to measure flicker bands")
    k = int(np.flatnonzero(band)[np.argmax(spec[band])])
    f0 = freqs[k]
    if 0 < k < spec.size - 1:
        a, b, c = np.log(spec[k - 1:k + 2] + 1e-12)
        den = a - 2 * b + c
        if den < 0:
            f0 = freqs[k] + 0.5 * (a - c) / den * (freqs[1] - freqs[0])
    y = np.arange(h, dtype=np.float64)

    def sine(yy: np.ndarray, amp: float, freq: float, phase: float, off: float) -> np.ndarray:
        return amp * np.sin(2 * np.pi * freq * yy + phase) + off

    ph0 = float(np.angle(np.sum(x * np.exp(-2j * np.pi * f0 * y))) + np.pi / 2)
    try:
        (amp, freq, _, _), _ = curve_fit(sine, y, x, p0=[x.std() * 1.4, f0, ph0, 0.0],
                                         maxfev=5000)
    except RuntimeError:
        amp, freq = x.std() * 1.4, f0
    contrast = float(abs(amp) / (x.std() + 1e-12))
    if not (1.5 / h <= abs(freq) <= 0.5) or contrast < 0.6:
        raise InputError("no clear flicker bands found across the lines of this image")
    return float(1.0 / abs(freq)), contrast


def readout_from_flicker(image: np.ndarray, frequency: float, *,
                         direction: str = "top-bottom") -> FlickerReadout:
    """Readout time from a frame of a light flickering at ``frequency`` Hz.

    Parameters
    ----------
    image : ndarray of shape (H, W[, C])
    frequency : float
        Flicker frequency in Hz (the LED's, or twice the mains frequency).
    direction : str
        Scan direction of the sensor.

    Returns
    -------
    FlickerReadout

    Examples
    --------
    Bands every 50 lines of a 1 kHz light on 500 lines: 10 periods, 10 ms.

    >>> y = np.arange(500)[:, None]
    >>> img = np.repeat(128 + 100 * np.sign(np.sin(2 * np.pi * y / 50)), 64, axis=1)
    >>> round(readout_from_flicker(img, 1000.0).milliseconds, 1)
    10.0
    """
    if not frequency > 0:
        raise InputError("the flicker frequency must be positive")
    period, contrast = band_period(image, direction)
    lines = to_top_bottom(np.asarray(image), direction).shape[0]
    ms = lines / (frequency * period) * 1e3
    return FlickerReadout(milliseconds=float(ms), period_lines=period, lines=lines,
                          contrast=contrast)
