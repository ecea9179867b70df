"""Quality metrics against ground truth: PSNR, SSIM and per-scanline displacement error.

PSNR and SSIM come from :mod:`skimage.metrics` on the 0-255 (or 0-1023) scale of the
images, over the valid region (an optional margin is cropped from every side). SSIM is
scikit-image's default (7x7 uniform window) on colour images with ``channel_axis``;
papers on Fastec/Carla differ in these details (see the README), so compare numbers
measured with the same function only.
"""

from __future__ import annotations

import numpy as np
from skimage.metrics import peak_signal_noise_ratio, structural_similarity

from .trajectory import FrameMotion

__all__ = ["psnr", "ssim", "displacement_error", "crop_margin"]


def crop_margin(image: np.ndarray, margin: int | tuple[int, int]) -> np.ndarray:
    """Drop ``margin`` pixels (or ``(mx, my)``) from every side."""
    mx, my = (margin, margin) if isinstance(margin, int) else margin
    h, w = image.shape[:2]
    return image[my:h - my or None, mx:w - mx or None]


def _rgb(img: np.ndarray) -> np.ndarray:
    return img[..., :3] if img.ndim == 3 and img.shape[2] == 4 else img


def _range(a: np.ndarray) -> float:
    return float(np.iinfo(a.dtype).max) if np.issubdtype(a.dtype, np.integer) else 1.0


def psnr(image: np.ndarray, truth: np.ndarray, margin: int | tuple[int, int] = 0) -> float:
    """Peak signal-to-noise ratio in dB (alpha ignored; identical images give 100 dB).

    Examples
    --------
    >>> a = np.full((8, 8), 100, np.uint8)
    >>> round(psnr(a, a + 1), 2)
    48.13
    """
    a, b = crop_margin(_rgb(image), margin), crop_margin(_rgb(truth), margin)
    if np.array_equal(a, b):
        return 100.0  # identical images: reported as 100 dB instead of infinity
    return float(peak_signal_noise_ratio(b, a, data_range=_range(truth)))


def ssim(image: np.ndarray, truth: np.ndarray, margin: int | tuple[int, int] = 0) -> float:
    """Structural similarity (scikit-image defaults; colour over ``channel_axis=-1``)."""
    a, b = crop_margin(_rgb(image), margin), crop_margin(_rgb(truth), margin)
    return float(structural_similarity(
        b, a, data_range=_range(truth), channel_axis=-1 if a.ndim == 3 else None))


def displacement_error(estimate: FrameMotion | None, truth: FrameMotion,
                       mask: np.ndarray | None = None) -> float:
    """Mean Euclidean error of the displacement (px), per scanline or per pixel.

    Parameters
    ----------
    estimate : FrameMotion or None
        Estimated motion; None means no correction (zero displacement).
    truth : FrameMotion
        True motion of the same frame.
    mask : ndarray of bool, shape (h, w), optional
        Pixels to score (e.g. the static background).

    Returns
    -------
    float
        With per-scanline displacements only: the mean over scanlines. When either side
        has a per-pixel field (dense methods, parallax scenes) or a mask is given: the
        mean over (masked) pixels, a scanline model being the same for every pixel.
    """
    if estimate is not None and estimate.displacement.shape != truth.displacement.shape:
        raise ValueError("estimate and truth have different numbers of scanlines")
    if mask is None and truth.field is None and (estimate is None or estimate.field is None):
        est = np.zeros_like(truth.displacement) if estimate is None else estimate.displacement
        return float(np.linalg.norm(est - truth.displacement, axis=1).mean())
    w = truth.field.shape[1] if truth.field is not None else (
        estimate.field.shape[1] if estimate is not None and estimate.field is not None
        else mask.shape[1])  # type: ignore[union-attr]
    true_f = truth.pixel_displacement(w)
    est_f = np.zeros_like(true_f) if estimate is None else estimate.pixel_displacement(w)
    err = np.linalg.norm(est_f - true_f, axis=-1)
    return float(err[mask].mean() if mask is not None else err.mean())
