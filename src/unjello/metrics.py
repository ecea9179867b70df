"""Quality metrics against ground truth: PSNR, SSIM and per-scanline displacement error.

PSNR and SSIM come from :mod:`skimage.metrics` on the 0-255 (or 0-1023) scale of the
images, over the valid region (an optional margin is cropped from every side). SSIM is
scikit-image's default (7x7 uniform window) on colour images with ``channel_axis``;
papers on Fastec/Carla differ in these details (see the README), so compare numbers
measured with the same function only.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .errors import InputError
from .io.source import read_frames
from .trajectory import FrameMotion, Trajectory

__all__ = ["psnr", "region_psnr", "ssim", "displacement_error", "crop_margin", "evaluate"]


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
    from skimage.metrics import peak_signal_noise_ratio  # on use: it imports scipy.stats

    return float(peak_signal_noise_ratio(b, a, data_range=_range(truth)))


def region_psnr(image: np.ndarray, truth: np.ndarray, mask: np.ndarray) -> float:
    """PSNR in dB (8-bit) over the pixels of ``mask`` (NaN where it has none).

    Examples
    --------
    >>> a = np.full((8, 8), 100, np.uint8); m = np.zeros((8, 8), bool); m[:2] = True
    >>> round(region_psnr(a, a + 1, m), 2)
    48.13
    """
    if not mask.any():
        return float("nan")
    err = (np.asarray(image, np.float64) - np.asarray(truth, np.float64))[mask]
    return float(10 * np.log10(255.0 ** 2 / max(float(np.mean(err ** 2)), 1e-10)))


def ssim(image: np.ndarray, truth: np.ndarray, margin: int | tuple[int, int] = 0) -> float:
    """Structural similarity (scikit-image defaults; colour over ``channel_axis=-1``)."""
    a, b = crop_margin(_rgb(image), margin), crop_margin(_rgb(truth), margin)
    from skimage.metrics import structural_similarity  # on use: it imports scipy.stats

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


def evaluate(output: str | os.PathLike, truth: str | os.PathLike, *,
             motion: str | os.PathLike | None = None,
             true_motion: str | os.PathLike | None = None, margin: int = 0) -> list[dict]:
    """Score corrected frames against global-shutter truth, frame by frame.

    Parameters
    ----------
    output, truth : path-like
        Videos or image folders with the same number of frames.
    motion, true_motion : path-like, optional
        Estimated and true trajectories (JSON); with both, the per-scanline displacement
        error is reported too (``true_motion`` defaults to ``<truth>.motion.json`` when
        that file exists).
    margin : int
        Pixels cropped from every side before PSNR/SSIM.

    Returns
    -------
    list of dict
        ``frame``, ``psnr``, ``ssim`` and, with trajectories, ``displacement_error`` and
        ``uncorrected_error`` (px).
    """
    if true_motion is None and Path(f"{truth}.motion.json").exists():
        true_motion = Path(f"{truth}.motion.json")
    est = Trajectory.load(motion) if motion else None
    tru = Trajectory.load(true_motion) if true_motion else None
    rows = []
    for i, (a, b) in enumerate(zip(read_frames(output), read_frames(truth), strict=False)):
        if a.shape[:2] != b.shape[:2]:
            raise InputError(f"frame {i}: output {a.shape[1]}x{a.shape[0]} and truth "
                             f"{b.shape[1]}x{b.shape[0]} differ in size")
        row = {"frame": i, "psnr": psnr(a, b, margin), "ssim": ssim(a, b, margin)}
        if tru is not None and i < len(tru.frames):
            row["uncorrected_error"] = displacement_error(None, tru.frames[i])
            if est is not None and i < len(est.frames):
                row["displacement_error"] = displacement_error(est.frames[i], tru.frames[i])
        rows.append(row)
    if not rows:
        raise InputError("no frames to compare")
    return rows
