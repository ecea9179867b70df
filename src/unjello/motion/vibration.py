"""Vibration near or above the frame rate (drone "jello"): detection and sinusoids.

Hand shake and pans change slowly within a frame; the vibration of a drone's or a car's
mount (20-40 Hz) changes from scanline to scanline. :func:`vibration_level` measures how
much the row flows of consecutive frame pairs wobble within a frame, and
:func:`detect_vibration` decides from the first frame pairs of a clip whether the dense
method should switch to :data:`VIBRATION`: a one-second window and a few sinusoids of
free frequency picked by :func:`sinusoid_pursuit` and solved with the camera trajectory
(:func:`unjello.motion.camera.solve_camera_trajectory`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import cv2
import numpy as np

__all__ = ["VIBRATION", "PROBE_CONTRAST", "PROBE_WAIT", "PROBE_TEXTURE", "textured",
           "vibration_level",
           "detect_vibration", "sinusoid_pursuit"]

#: Settings for vibration near or above the frame rate (drone "jello"): a symmetric window
#: of about one beat period, a trajectory that may bend at scanline resolution, six
#: sinusoids of free frequency, DIS medium's own refinement at full resolution
#: (``docs/tuning.md``; the polished flow lost 0.06x on the simulated drone jello:
#: ``docs/measurements.md``).
VIBRATION: dict[str, Any] = {"history": 16, "window": 16, "smoothness": 1e-7, "sinusoids": 6,
                             "refinement": None, "detail": "full"}

# Vibration is detected (:func:`vibration_level`) above this wobble, as a fraction of the
# frame height, making up at least this share of the non-steady row flow: the share tells
# jello from shake and stops, the wobble keeps still or steady clips out (``docs/tuning.md``).
_WOBBLE, _WOBBLE_SHARE = 0.002, 0.5

# ... and below this one: row flows that wobble by more than 3 % of the height between
# frame pairs are flow that failed, not a mount's vibration (simulated jello 0.5-1.3 %;
# a steady 25 %-a-frame pan behind flat poles whose flow failed 6.9 %, and corrected as
# vibration it came out 2.5x worse than uncorrected: ``docs/measurements.md``).
_WOBBLE_MAX = 0.03

# Frame pairs enter the vibration test only where both frames have this grey-level
# standard deviation (0-255): the noise of a fade from black gave a simulated pan a wobble
# of 0.42 % and the Big Buck Bunny trailer 3.3 %, both "vibration". The test waits for
# ``probe`` such pairs, but no longer than this many times ``probe`` pairs in all.
PROBE_CONTRAST, PROBE_WAIT = 6.0, 2

# Only pixels of two-dimensional texture enter the test (:func:`textured`): along an edge
# the flow is not measured but filled in (the aperture problem). A pan over a flat sky
# with flat poles passing in front (sky rows: only the poles' upright edges) wobbled
# 1.39 % of the height in the vertical flow, was corrected as vibration, and came out 12x
# worse than uncorrected; with them left out, 0 (``docs/measurements.md``).
PROBE_TEXTURE = 0.05


def textured(image: np.ndarray, share: float = PROBE_TEXTURE) -> np.ndarray:
    """Pixels of two-dimensional texture: corners and texture, not edges or flat areas.

    Where the smaller eigenvalue of the local structure tensor (5 x 5 px,
    :func:`cv2.cornerMinEigenVal`) is at least ``share`` of its 90th percentile in the
    frame. Bool mask of ``image``'s shape.
    """
    e = cv2.cornerMinEigenVal(np.ascontiguousarray(image, np.float32), 5)
    return e >= share * float(np.percentile(e, 90))


def vibration_level(left: list[tuple[np.ndarray, np.ndarray]],
                    right: list[tuple[np.ndarray, np.ndarray]], height: int
                    ) -> tuple[float, float]:
    """How much the row flows of consecutive frame pairs wobble within a frame.

    The part of each row's flow that is the same in every pair (perspective, parallax
    of a steady pan) is removed; the rest, in scanline order (time, for a readout near
    one frame), is split into its slow part (a running mean over one frame) and the
    wobble around it. Hand shake and pans are slow within a frame; vibration near or
    above the frame rate is not. Vibration moves whole rows: the wobble is measured as
    what the left and right halves of the frame share (their cross-power), so a nearer
    layer or a moving object sliding through the rows of one half does not count.

    Parameters
    ----------
    left, right : list of (row indices, row flows)
        Per pair, in order: :func:`row_flows` of the left and of the right half.
    height : int
        Rows per frame.

    Returns
    -------
    wobble : float
        RMS of the shared wobble, as a fraction of the frame height.
    share : float
        Its share of the RMS of the non-stationary flow (0-1).
    """
    if len(left) < 3 or len(left) != len(right):
        return 0.0, 0.0
    per = np.full((2, len(left), height, 2), np.nan)
    for side, rows in enumerate((left, right)):
        for k, (y, flow) in enumerate(rows):
            per[side, k, y.astype(np.int64)] = flow
    seen = np.isfinite(per).all(axis=(0, 1, 3))
    if seen.sum() < height // 4:
        return 0.0, 0.0
    moving = per[:, :, seen] - per[:, :, seen].mean(axis=1, keepdims=True)
    moving = moving.reshape(2, -1, 2).astype(np.float64)
    wobble = [m - cv2.blur(m[:, None, :], (1, int(seen.sum())),
                           borderType=cv2.BORDER_REPLICATE)[:, 0, :] for m in moving]
    shared = float(np.sqrt(max(0.0, (wobble[0] * wobble[1]).sum(axis=1).mean())))
    total = float(np.sqrt(max(0.0, (moving[0] * moving[1]).sum(axis=1).mean())))
    return shared / height, min(1.0, shared / total) if total > 0 else 0.0


def detect_vibration(halves: Sequence[tuple[tuple[np.ndarray, np.ndarray], ...]], height: int,
                     probe: int) -> float | None:
    """Return the wobble (fraction of the height) if the frame pairs vibrate, else None.

    Parameters
    ----------
    halves : list of (left, right)
        Per frame pair, in order: :func:`half_row_flows` of its flow.
    height : int
        Rows per frame.
    probe : int
        Fewer pairs than this are never said to vibrate.
    """
    if len(halves) < probe:
        return None
    wobble, share = vibration_level([p[0] for p in halves], [p[1] for p in halves], height)
    return wobble if _WOBBLE <= wobble <= _WOBBLE_MAX and share >= _WOBBLE_SHARE else None


def sinusoid_pursuit(t_a: np.ndarray, t_b: np.ndarray, delta: np.ndarray,
                     weight: np.ndarray, base: np.ndarray, count: int,
                     max_cycles: float = 1.6, ridge: float = 0.0) -> tuple[np.ndarray, float]:
    """Sinusoids of a trajectory seen through its differences ``c(t_a) - c(t_b) = delta``.

    Orthogonal matching pursuit: ``count`` times, the frequency (0.01 to ``max_cycles``
    cycles per unit of time, on a 0.0025 grid, shared by x and y) whose cosine and sine
    explain most of what ``base`` and the sinusoids so far leave of ``delta``; then all
    amplitudes are refitted.

    Parameters
    ----------
    t_a, t_b : ndarray of shape (m,)
        Times of the two ends of each equation.
    delta : ndarray of shape (m, 2)
        Observed differences.
    weight : ndarray of shape (m,)
        Confidence of each equation.
    base : ndarray of shape (m, b)
        Other columns of the model (``b`` may be 0), fitted with the sinusoids.
    count : int
        Sinusoids to pick.
    max_cycles : float
        Highest frequency considered.
    ridge : float
        Penalty on the squared amplitudes, relative to the total weight, in the choice:
        a sinusoid the differences barely see (near a multiple of the frame rate) must
        not be picked to fit noise with a huge amplitude.

    Returns
    -------
    freqs : ndarray of shape (count,)
        The frequencies picked, in order.
    residual : float
        Weighted residual energy of the final fit.

    Examples
    --------
    >>> t_a = np.linspace(1, 9, 400); t_b = t_a - 1.0
    >>> c = lambda t: np.stack([np.sin(2 * np.pi * 0.77 * t), np.cos(2 * np.pi * 1.3 * t)], 1)
    >>> f, r = sinusoid_pursuit(t_a, t_b, c(t_a) - c(t_b), np.ones(400), np.zeros((400, 0)), 2)
    >>> sorted(np.round(f, 2).tolist()), bool(r < 1e-9)
    ([0.77, 1.3], True)
    """
    sw = np.sqrt(weight)[:, None]
    rhs = delta * sw
    cols = [base * sw]
    resid = rhs - cols[0] @ np.linalg.lstsq(cols[0], rhs, rcond=None)[0] if base.shape[1] else rhs
    grid = np.arange(0.01, max_cycles, 0.0025)
    pa, pb = (2 * np.pi) * t_a[:, None] * grid, (2 * np.pi) * t_b[:, None] * grid
    cos = (np.cos(pa) - np.cos(pb)) * sw
    sin = (np.sin(pa) - np.sin(pb)) * sw
    lam = ridge * float(weight.sum())
    cc, ss, cs = (cos * cos).sum(0) + lam, (sin * sin).sum(0) + lam, (cos * sin).sum(0)
    det = cc * ss - cs ** 2 + 1e-12
    picked: list[int] = []
    for _ in range(count):
        rc, rs = cos.T @ resid, sin.T @ resid  # (frequencies, 2)
        # Energy of the residual's projection on span{cos_f, sin_f}, x and y together.
        gain = ((ss[:, None] * rc ** 2 - 2 * cs[:, None] * rc * rs + cc[:, None] * rs ** 2)
                / det[:, None]).sum(axis=1)
        f = int(np.argmax(gain))
        picked.append(f)
        cols.append(np.stack([cos[:, f], sin[:, f]], axis=1))
        a = np.concatenate(cols, axis=1)
        resid = rhs - a @ np.linalg.lstsq(a, rhs, rcond=None)[0]
    return grid[picked], float((resid ** 2).sum())


