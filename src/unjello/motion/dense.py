"""Beyond the paper: dense per-pixel motion with a scanline-resolution camera trajectory.

The paper models one translation per scanline, smoothed by a Bezier curve through one
sample per frame: it cannot follow vibration (jello), hand shake, parallax or moving
objects (its Sec. VII). This method keeps the paper's rolling-shutter timing and
replaces the motion model:

1. **Dense correspondences.** DIS optical flow (OpenCV) from each frame to the previous
   one, and its inverse the other way; a forward-backward consistency check marks
   unreliable pixels (flow that folds, content leaving the frame).
2. **Camera trajectory at scanline resolution.** Row ``y`` of frame ``k`` is imaged at
   ``t = t_k + rho y / h`` and its content was at row ``y + f_y`` of frame ``k - 1``,
   imaged at ``t' = t_{k-1} + rho (y + f_y) / h`` (the paper's eq. 10 with readout
   ``rho``: two corresponding points are ``dt + rho (y - y') / h`` apart in time). The
   robust (median) flow of each row gives one equation ``c(t) - c(t') = -f`` on the
   camera's image-plane trajectory ``c``, sampled on a fine time grid (``grid`` samples
   per readout, linear in between). All rows of the frames around ``n`` are solved
   together by regularised least squares (a small penalty on the second difference of
   ``c`` selects the smoothest trajectory among those the data allow). Because every
   row contributes its own equation, motion that changes within a frame -- hand shake,
   23-40 Hz drone vibration -- is followed, not smoothed away; only components exactly
   periodic with the frame interval are invisible to frame differences, and the
   regulariser keeps those small.
3. **Per-pixel residual.** What the camera trajectory does not explain (parallax,
   independently moving objects) is the residual flow of each pixel; where both
   neighbours exist its position over time is the quadratic through the three frames
   (residual 0 at the pixel's own time), else a straight line. Where the flow fails the
   check on both sides, the pixel falls back to the camera trajectory alone, and the
   fraction of such pixels is reported in the frame's ``note``.

Each pixel ``s`` then belongs at ``p = s - D(s)`` with
``D(s) = c(t_s) - c(t_ref) - R_s(t_ref)`` (eq. 26 per pixel), applied by the dense
backward warp (:func:`unjello.warp.field_maps`, :func:`unjello.warp.apply_maps`). No
still first frame is assumed: every frame is corrected to its own reference time.
"""

from __future__ import annotations

import dataclasses
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
from scipy import linalg
from threadpoolctl import ThreadpoolController

from ..timing import SensorTiming
from ..trajectory import FrameMotion
from ..warp import pixel_grid

__all__ = ["DenseConfig", "DenseMethod", "VIBRATION", "CameraSolution", "optical_flow",
           "solve_camera_trajectory", "row_flows", "half_row_flows", "flow_pair", "landing",
           "refine_motion_edges", "snap_to_global", "invert_flow", "vibration_level",
           "detect_vibration", "sinusoid_pursuit"]

# The camera solves are small (a few hundred unknowns): one BLAS thread is faster, and
# BLAS threads spinning beside the encoder's cost ten times more (measured: 25 vs 3 ms).
_BLAS = ThreadpoolController()

# Up to this width the medium preset estimates flow at full resolution (its level 1 on
# a 640 px copy is 320 px wide). Measured on 320x240 (benchmarks/synthetic.py): moving
# object background 0.035x -> 0.016x, parallax 0.038x -> 0.019x, hand shake 0.069x ->
# 0.063x, at 1.5-1.75x the flow's time.
_FULL_RES_WIDTH = 480

# Ridge on the amplitudes of the trajectory's sinusoids, relative to the total weight, in
# their choice and their solve. Measured (benchmarks/synthetic.py, --vibration on): 1e-6
# let sinusoids near the frame rate, which the frame differences barely see, fit noise
# (diagonal pan 4.1x, moving object 1.3x the uncorrected error); 1e-3 is as safe as no
# sinusoids on every case and gives the 2 s jello clip 0.090x (0.182x without; 0.099x
# as shipped, picking every 8 frames from every 4th row); 3e-3 0.125x, 1e-2 0.146x.
_SINE_RIDGE = 1e-3

_PRESETS = {"ultrafast": cv2.DISOPTICAL_FLOW_PRESET_ULTRAFAST,
            "fast": cv2.DISOPTICAL_FLOW_PRESET_FAST,
            "medium": cv2.DISOPTICAL_FLOW_PRESET_MEDIUM}


@dataclass(frozen=True)
class DenseConfig:
    """Settings of the dense method.

    Parameters
    ----------
    flow_preset : {'ultrafast', 'fast', 'medium'}
        DIS optical flow preset.
    work_width : int
        Motion is estimated on frames downscaled to at most this width (0: full size);
        the per-pixel field is returned at that resolution, in full-frame pixels.
        Measured with the medium preset (full resolution up to 480 px): against a 640 px
        copy at its half-resolution level, 1080p runs 1.35x faster at equal or better
        PSNR (simulated pan, shake, parallax, moving object), and the 640 px research
        pairs gain 0.1 dB (Fastec) and 0.4 dB (Carla).
    grid : int
        Camera trajectory samples per readout time.
    smoothness : float
        Weight of the second-difference penalty on the camera trajectory. Measured
        (``benchmarks/synthetic.py``; 1e-2 / 3e-3 / 1e-3): hand shake 0.063x / 0.039x /
        0.033x of the uncorrected error, pan then stop 0.047x / 0.039x / 0.034x, the
        other cases within 0.002x; but six-frame parallax clips (224x160, 7 px/frame)
        0.038x / 0.053x / 0.083x (35.65 / 35.46 / 34.85 dB).
    pair_smoothness : float
        The weight used instead, when larger, where a frame's window holds a single frame
        pair (a two-frame clip): the acceleration of the camera and a velocity varying
        with the row (perspective) then explain the same flows, and only the penalty
        decides. Measured on the research pairs (before ``advect``): 1e-2 gives Fastec
        28.32 dB, Carla 31.19 dB; 3e-3 gives 28.18 and 31.03, 1e-3 27.76 and 30.30. With
        ``advect``: 1e-2 28.78 / 31.37, 3e-2 28.80 / 31.37, 1e-1 28.81 / 31.36; with one
        refinement iteration and ``consistency`` 3: 1e-2 28.76 / 31.56, 3e-2 28.79 /
        31.56. Three Fastec frames
        solved together are as good with 3e-3 or 1e-3 as with 1e-2 (28.38, 28.43 and
        28.34 dB for their last two frames).
    window : int
        Frame pairs after a frame used to solve its camera trajectory (the look-ahead:
        a frame's motion is final this many frames later).
    history : int
        Frame pairs before a frame used too. Vibration near the frame rate (31 Hz at
        30 fps) barely changes from frame to frame; telling it apart takes about one beat
        period of history (30 frames at 31 Hz).
    consistency : float
        Forward-backward flow disagreement (px) above which a pixel is unreliable.
        Measured (with one refinement iteration): 10 px gave the research pairs Fastec
        28.76 / Carla 31.48 dB, 5 px 28.77 / 31.54, 3 px 28.76 / 31.56; the suite alike
        or better with 3 (parallax 0.021x vs 0.022x, pan 0.010x vs 0.011x).
    finest_scale : int, optional
        DIS finest pyramid level (0 = full resolution). Default: the preset's, except
        that the ``medium`` preset works at full resolution on copies up to 480 px wide,
        so that small frames get flow as fine as large ones (about 320 px across).
    refinement : int, optional
        Variational refinement iterations of the ``medium`` preset at each pyramid level
        (``None``: the preset's 5; the other presets keep theirs). Measured on the
        research pairs (``benchmarks/pairs.py``, Fastec / Carla dB, DIS ms per flow on
        480x360): 5 iterations 28.78 / 31.37, 66 ms; 2: 28.75 / 31.49, 51 ms; 1: 28.77 /
        31.48, 45 ms; 0: 28.80 / 31.23, 30 ms. On the simulated suite
        (``benchmarks/synthetic.py``) 1 against 5: PSNR within 0.02 dB except the 2 s
        jello clip (35.09 vs 35.23 dB); displacement error 5-20 % higher (hand shake
        0.046x vs 0.039x, parallax 0.022x vs 0.019x). :data:`VIBRATION` keeps 5.
    fill_sigma : float
        Where the flow is unreliable, the residual motion is the Gaussian-weighted
        average (this sigma, px) of the reliable residuals around it.
    detect_vibration : bool
        Look at the first ``probe`` frame pairs and switch to :data:`VIBRATION` when
        their row flows wobble from row to row (see :func:`vibration_level`).
    probe : int
        Frame pairs looked at before the first frame is emitted, to decide: pairs of
        frames with contrast (grey-level standard deviation of at least 6, so not the
        start of a fade from black), waiting at most twice this many pairs; with fewer
        (short clips, long fades) the clip is never switched.
    sinusoids : int
        Sinusoids of free frequency (up to 1.6 cycles per frame interval) added to the
        camera trajectory, outside its smoothness penalty (vibration): picked from what
        the smooth trajectory leaves (:func:`sinusoid_pursuit`), then solved together.
    advect : bool
        Where a frame has one neighbour (the ends of a clip, a frame pair), carry each
        pixel's velocity through the smooth (projective) part of the flow field on its way
        to the reference time, instead of a constant velocity per pixel: research pairs
        Fastec 28.32 -> 28.78 dB, Carla 31.19 -> 31.37 dB (see
        :func:`_advected_velocity`).
    edge_refine : bool
        Near motion boundaries, give each pixel the flow of the side it matches
        (:func:`refine_motion_edges`; per-pixel mode only): a third less displacement
        error on parallax and moving objects, the same PSNR, up to a third more time on
        busy scenes (Carla town sequence, 640x448: 0.15 -> 0.20 s a frame), hence
        off by default (``--edge-refine``).
    snap_window : int
        Pixels whose neighbourhood the frame's global (projective) motion explains as well
        as their own flow take the global motion (:func:`snap_to_global`; this patch side
        in px, 0: off). It undoes the flow's smoothing across the edges of moving objects
        and its noise on the rest of the scene.
    per_pixel : bool
        Model each pixel's residual motion (parallax, moving objects) on top of the
        camera trajectory. False: the camera trajectory and row velocity alone, one
        displacement per scanline -- one flow per frame and a per-scanline warp, for
        speed (``--camera-only``).
    """

    flow_preset: str = "medium"
    work_width: int = 480
    grid: int = 64
    smoothness: float = 3e-3
    pair_smoothness: float = 3e-2
    window: int = 2
    history: int = 2
    consistency: float = 3.0
    finest_scale: int | None = None
    refinement: int | None = 1
    fill_sigma: float = 12.0
    detect_vibration: bool = True
    probe: int = 8
    sinusoids: int = 0
    advect: bool = True
    edge_refine: bool = False
    snap_window: int = 9
    per_pixel: bool = True


#: Settings for vibration near or above the frame rate (drone "jello"): a symmetric window
#: of about one beat period (31 Hz at 30 fps beats once a second), a trajectory that may
#: bend at scanline resolution, and six sinusoids of free frequency (a vibration is a few
#: of them: with them the 2 s jello clip of ``benchmarks/synthetic.py`` went from 0.182x
#: to 0.099x of the uncorrected error, the 12-frame one from 0.699x to 0.633x). Costs some
#: accuracy on parallax (0.049x instead of 0.019x) and a 16-frame look-ahead. The flow
#: keeps DIS medium's five refinement iterations: with one, the suite's diagonal pan went
#: from 0.020x to 0.032x and the moving object's background from 0.029x to 0.047x.
VIBRATION: dict[str, Any] = {"history": 16, "window": 16, "smoothness": 1e-7, "sinusoids": 6,
                             "refinement": None}

# Vibration is detected (:func:`vibration_level`) above this wobble, as a fraction of the
# frame height, making up at least this share of the non-steady row flow. Measured on 10
# simulated frames (224x160 and 320x240, two photos): jello 0.87-1.3 % / 0.84; hand shake
# 0.14-0.21 % / 0.11; pan then stop 0.13-0.19 % / 0.09; parallax and a moving object
# 0.02 % and less. On 12 frames at readouts 0.3-1.0: jello 0.54-0.85 % / 0.57-0.85, hand
# shake up to 0.27 % / 0.24, a stop up to 0.19 % / 0.13; the real hand-held phone clip
# 0.17 % / 0.23. The share tells them apart; the wobble threshold only keeps still or
# steady clips (a constant pan: 0.01 %, share up to 1.0) out. 720p Big Buck Bunny with a
# 2 px jello read in 0.6 of the frame interval: 0.29 % / 0.78 (missed at 0.4 %).
_WOBBLE, _WOBBLE_SHARE = 0.002, 0.5

# Frame pairs enter the vibration test only where both frames have this grey-level
# standard deviation (0-255): the noise of a fade from black gave a simulated pan a wobble
# of 0.42 % and the Big Buck Bunny trailer 3.3 %, both "vibration". The test waits for
# ``probe`` such pairs, but no longer than this many times ``probe`` pairs in all.
_PROBE_CONTRAST, _PROBE_WAIT = 6.0, 2


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
    return wobble if wobble >= _WOBBLE and share >= _WOBBLE_SHARE else None


def optical_flow(a: np.ndarray, b: np.ndarray, preset: str = "medium",
                 max_width: int = 960, finest_scale: int | None = None,
                 refinement: int | None = None) -> np.ndarray:
    """Dense flow ``F`` with ``a(s) ~ b(s + F(s))`` (DIS, OpenCV).

    Parameters
    ----------
    a, b : ndarray of shape (H, W), 0-255
        Grey frames.
    preset : str
        DIS preset.
    max_width : int
        Compute on frames downscaled to at most this width (0: full size).
    finest_scale : int, optional
        DIS finest pyramid level (0 = full resolution); default the preset's, or 0 for
        ``medium`` on (downscaled) frames up to 480 px wide.
    refinement : int, optional
        Variational refinement iterations at each pyramid level; default the preset's.

    Returns
    -------
    ndarray of shape (H, W, 2), float32
        ``(dx, dy)`` in full-resolution pixels.
    """
    h, w = a.shape
    scale = min(1.0, max_width / w) if max_width else 1.0
    a8 = np.clip(a, 0, 255).astype(np.uint8)
    b8 = np.clip(b, 0, 255).astype(np.uint8)
    if scale < 1.0:
        size = (max(8, round(w * scale)), max(8, round(h * scale)))
        a8 = cv2.resize(a8, size, interpolation=cv2.INTER_AREA)
        b8 = cv2.resize(b8, size, interpolation=cv2.INTER_AREA)
    dis = cv2.DISOpticalFlow_create(_PRESETS[preset])  # type: ignore[attr-defined]
    if finest_scale is None and preset == "medium" and a8.shape[1] <= _FULL_RES_WIDTH:
        finest_scale = 0  # the preset's level 1 would be coarser than on larger frames
    if finest_scale is not None:
        dis.setFinestScale(finest_scale)
    if refinement is not None:
        dis.setVariationalRefinementIterations(refinement)
    flow = dis.calc(a8, b8, None)
    if scale < 1.0:
        sx, sy = w / a8.shape[1], h / a8.shape[0]
        flow = cv2.resize(flow, (w, h), interpolation=cv2.INTER_LINEAR)
        flow[..., 0] *= sx
        flow[..., 1] *= sy
    return flow


def landing(flow: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where each pixel's flow lands (x, y), and whether that is inside the frame."""
    h, w = flow.shape[:2]
    gx = np.arange(w, dtype=np.float32)[None, :] + flow[..., 0]
    gy = np.arange(h, dtype=np.float32)[:, None] + flow[..., 1]
    return gx, gy, (gx >= 0) & (gx <= w - 1) & (gy >= 0) & (gy <= h - 1)


def _consistent(fwd: np.ndarray, bwd: np.ndarray, tol: float) -> np.ndarray:
    """Pixels whose flow lands inside the frame and comes back within ``tol`` px."""
    gx, gy, inside = landing(fwd)
    back = cv2.remap(bwd, gx, gy, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    err = np.hypot(fwd[..., 0] + back[..., 0], fwd[..., 1] + back[..., 1])
    return inside & (err <= tol)


def _interp_matrix(times: np.ndarray, t0: float, step: float, n: int) -> tuple[np.ndarray,
                                                                                  np.ndarray,
                                                                                  np.ndarray]:
    """Return indices and weights of linear interpolation of grid values at ``times``."""
    u = np.clip((times - t0) / step, 0, n - 1 - 1e-9)
    i0 = np.floor(u).astype(np.int64)
    f = u - i0
    return i0, 1.0 - f, f


def _second_difference_band(n: int) -> np.ndarray:
    """``D2^T D2`` for the second-difference operator on ``n`` samples, as a 3-row upper band.

    Row ``2 - d`` holds the ``d``-th superdiagonal (LAPACK's upper band storage, right
    aligned): the diagonal is ``1, 5, 6, ..., 6, 5, 1``, the first superdiagonal
    ``-2, -4, ..., -4, -2``, the second all ones.
    """
    band = np.zeros((3, n))
    if n >= 3:
        ones = np.ones(n - 2)
        band[2] = np.convolve(ones, [1.0, 4.0, 1.0])
        band[1, 1:] = np.convolve(ones, [-2.0, -2.0])
        band[0, 2:] = ones
    return band


def _band_to_dense(band: np.ndarray) -> np.ndarray:
    """Return the symmetric matrix whose upper band (LAPACK storage) is ``band``."""
    bw, n = band.shape[0] - 1, band.shape[1]
    full = np.zeros((n, n))
    for d in range(bw + 1):
        full[np.arange(n - d), np.arange(d, n)] = band[bw - d, d:]
    return full + np.triu(full, 1).T


def _solve_bordered_banded(band: np.ndarray, b: np.ndarray, c: np.ndarray,
                           rhs: np.ndarray) -> np.ndarray:
    """Solve ``[[a, b], [b^T, c]] x = rhs`` with ``a`` banded and symmetric positive definite.

    ``a`` is given by its upper band (LAPACK storage). The trajectory block ``a`` couples
    samples about one frame interval apart, so it is banded; the few row-velocity
    unknowns border it. Banded Cholesky of ``a`` and the Schur complement of the border
    keep the cost linear in the window's length, so long windows (needed to resolve
    vibration near the frame rate) stay cheap.
    """
    bw, n, k = band.shape[0] - 1, band.shape[1], c.shape[0]
    if bw > n // 3:  # hardly banded: a dense solve is as good
        a = _band_to_dense(band)
        full = np.block([[a, b], [b.T, c]]) if k else a
        return np.linalg.solve(full, rhs)
    factor = linalg.cholesky_banded(band)
    x = linalg.cho_solve_banded((factor, False), np.concatenate([b, rhs[:n]], axis=1))
    if not k:
        return x
    ainv_b, ainv_r = x[:, :k], x[:, k:]
    u = np.linalg.solve(c - b.T @ ainv_b, rhs[n:] - b.T @ ainv_r)
    return np.concatenate([ainv_r - ainv_b @ u, u])


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


@dataclass(frozen=True)
class CameraSolution:
    """Solution of :func:`solve_camera_trajectory`.

    Attributes
    ----------
    t0 : float
        Time of the first grid sample.
    step : float
        Grid spacing.
    c : ndarray of shape (n, 2)
        Trajectory samples at ``t0 + k * step``, zero mean.
    u : ndarray of shape (row_knots, 2)
        Row velocity at ``rows = linspace(0, 1, row_knots)`` (empty without rows).
    cost : float
        The minimised objective (misfit plus penalties), to compare models.
    """

    t0: float
    step: float
    c: np.ndarray
    u: np.ndarray
    cost: float

    def differences(self, t_a: np.ndarray, t_b: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """Return the left side ``c(t_a) - c(t_b) + u(y) (t_a - t_b)`` of the equations."""
        grid_t = self.t0 + self.step * np.arange(self.c.shape[0])
        knots = np.linspace(0.0, 1.0, self.u.shape[0])
        return np.stack([np.interp(t_a, grid_t, self.c[:, i]) - np.interp(t_b, grid_t,
                                                                        self.c[:, i])
                         + np.interp(rows, knots, self.u[:, i]) * (t_a - t_b)
                         for i in range(2)], axis=1)


def solve_camera_trajectory(t_a: np.ndarray, t_b: np.ndarray, rows: np.ndarray | None,
                            delta: np.ndarray, weight: np.ndarray, step: float,
                            smoothness: float, row_knots: int = 16,
                            freqs: np.ndarray | None = None) -> CameraSolution:
    """Solve ``c(t_a) - c(t_b) + u(y) (t_a - t_b) = delta`` by regularised least squares.

    ``c`` is the camera's image-plane trajectory on a time grid; ``u`` is a velocity that
    depends on the row only and is shared by all frame pairs: it absorbs what varies
    along the frame but not over time (perspective, zoom, a tilted ground plane), so
    that ``c`` changes within a frame only where the frames disagree over time (shake,
    vibration). With a single pair the two cannot be told apart, and the penalty on the
    acceleration of ``c`` gives the spatial explanation: constant velocity per row.

    Parameters
    ----------
    t_a, t_b : ndarray of shape (m,)
        Times of the two ends of each equation (later frame, earlier frame).
    rows : ndarray of shape (m,) or None
        Row of each equation in the later frame, as a fraction of the height; None
        leaves the row velocity ``u`` out of the model.
    delta : ndarray of shape (m, 2)
        Observed displacement of the row's content from ``t_b`` to ``t_a``.
    weight : ndarray of shape (m,)
        Confidence of each equation.
    step : float
        Grid spacing of ``c`` in time.
    smoothness : float
        Weight of the penalty on the acceleration of ``c``.
    row_knots : int
        Knots of ``u`` over the frame height (linear in between).
    freqs : ndarray, optional
        Frequencies (cycles per unit of time) of sinusoids added to ``c`` with free
        amplitudes, outside the smoothness penalty (vibration; see
        :func:`sinusoid_pursuit`).

    Returns
    -------
    CameraSolution

    Examples
    --------
    A constant velocity of 4 px per unit time:

    >>> ta = np.linspace(1, 2, 50); tb = ta - 1.0; y = np.linspace(0, 1, 50)
    >>> sol = solve_camera_trajectory(ta, tb, y, np.tile([4.0, 0.0], (50, 1)),
    ...                               np.ones(50), 0.05, 0.05)
    >>> bool(np.allclose(np.diff(sol.c[:, 0]) / 0.05 + sol.u[0, 0], 4.0, atol=1e-2))
    True
    """
    t0 = float(min(t_a.min(), t_b.min())) - step
    t1 = float(max(t_a.max(), t_b.max())) + step
    n = int(np.ceil((t1 - t0) / step)) + 2
    ku = row_knots if rows is not None else 0
    freqs = np.zeros(0) if freqs is None else np.asarray(freqs, dtype=np.float64)
    k = ku + 2 * freqs.size
    m = t_a.size
    sw = np.sqrt(weight)
    rhs = delta * sw[:, None]
    ia, wa0, wa1 = _interp_matrix(t_a, t0, step, n)
    ib, wb0, wb1 = _interp_matrix(t_b, t0, step, n)
    # Each equation touches four samples of c (linear interpolation at both ends) ...
    cols = np.stack([ia, ia + 1, ib, ib + 1], axis=1)
    vals = np.stack([wa0, wa1, -wb0, -wb1], axis=1) * sw[:, None]
    # ... and the border unknowns: u's two knots around the row, the sinusoids.
    border = np.zeros((m, k))
    if rows is not None:
        ir, wr0, wr1 = _interp_matrix(rows, 0.0, 1.0 / (ku - 1), ku)
        gap = t_a - t_b
        r = np.arange(m)
        border[r, ir] = gap * wr0
        border[r, ir + 1] = gap * wr1
    if freqs.size:  # each sinusoid's cosine and sine, seen through the differences
        pa, pb = 2 * np.pi * (t_a - t0)[:, None] * freqs, 2 * np.pi * (t_b - t0)[:, None] * freqs
        border[:, ku:] = np.concatenate([np.cos(pa) - np.cos(pb), np.sin(pa) - np.sin(pb)],
                                        axis=1)
    border *= sw[:, None]
    # Normal equations: the c block straight into LAPACK's upper band storage.
    bw = max(2, int((cols.max(axis=1) - cols.min(axis=1)).max()))
    pi, qi = np.meshgrid(np.arange(4), np.arange(4), indexing="ij")
    ci, cj = cols[:, pi.ravel()], cols[:, qi.ravel()]
    upper = ci <= cj
    products = vals[:, pi.ravel()] * vals[:, qi.ravel()]
    band = np.bincount(((bw + ci - cj) * n + cj)[upper], products[upper],
                       minlength=(bw + 1) * n).reshape(bw + 1, n)
    def c_rows(x: np.ndarray) -> np.ndarray:
        """``A_c^T x`` for a matrix ``x`` of shape (m, j): scatter-add into c's rows."""
        j = x.shape[1]
        idx = cols[:, :, None] * j + np.arange(j)
        return np.bincount(idx.ravel(), (vals[:, :, None] * x[:, None, :]).ravel(),
                           minlength=n * j).reshape(n, j)

    atb = np.concatenate([c_rows(rhs), border.T @ rhs])
    b_cu = c_rows(border)
    c_uu = border.T @ border
    scale = weight.sum()
    # Acceleration of c: sum (d2 c / step^2)^2 * step ~ integral of the squared acceleration.
    band[bw - 2:] += smoothness * scale / step**3 * _second_difference_band(n)
    if ku:
        # u: small roughness and ridge penalties (a constant velocity belongs to c).
        c_uu[:ku, :ku] += (1e-3 * scale * _band_to_dense(_second_difference_band(ku))
                           + 1e-4 * scale * np.eye(ku))
    if freqs.size:  # near a multiple of the frame rate a sinusoid is nearly invisible
        c_uu[ku:, ku:] += _SINE_RIDGE * scale * np.eye(k - ku)
    jitter = 1e-9 * ((band[bw].sum() + np.trace(c_uu)) / (n + k) + 1e-12)
    band[bw] += jitter
    c_uu += jitter * np.eye(k)
    with _BLAS.limit(limits=1, user_api="blas"):
        sol = _solve_bordered_banded(band, b_cu, c_uu, atb)
    cost = float((rhs ** 2).sum() - (sol * atb).sum())
    c, u = sol[:n], sol[n:n + ku]
    if freqs.size:
        ph = 2 * np.pi * (step * np.arange(n))[:, None] * freqs
        c = c + np.concatenate([np.cos(ph), np.sin(ph)], axis=1) @ sol[n + ku:]
    return CameraSolution(t0, step, c - c.mean(axis=0), u, cost)


def _shorth(values: np.ndarray) -> np.ndarray:
    """Centre of the densest half of each row's values (NaN = missing), per channel.

    The midpoint of the shortest interval holding half the samples (the "shorth") follows
    the dominant motion of a row even when an independently moving object covers much of
    it, where a median would be pulled towards the object.

    Parameters
    ----------
    values : ndarray of shape (rows, n, c)

    Returns
    -------
    ndarray of shape (rows, c)
    """
    srt = np.sort(values, axis=1)  # NaN last
    valid = np.isfinite(srt).sum(axis=1)  # (rows, c)
    rows, n, c = srt.shape
    half = np.maximum(valid // 2, 1)
    idx = np.arange(n)[None, :, None]
    end = idx + half[:, None, :]
    ends = np.take_along_axis(srt, np.minimum(end, n - 1), axis=1)
    width = np.where(end < valid[:, None, :], ends - srt, np.inf)
    best = np.argmin(width, axis=1)  # (rows, c)
    lo = np.take_along_axis(srt, best[:, None, :], axis=1)[:, 0]
    hi = np.take_along_axis(srt, np.minimum(best + half, n - 1)[:, None, :], axis=1)[:, 0]
    return 0.5 * (lo + hi)


def row_flows(flow: np.ndarray, ok: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Dominant flow of every row with enough reliable pixels.

    Parameters
    ----------
    flow : ndarray of shape (h, w, 2)
        Flow from a frame to its previous one.
    ok : ndarray of bool, shape (h, w)
        Reliable pixels.

    Returns
    -------
    rows : ndarray of shape (m,)
        Row indices (float).
    flow : ndarray of shape (m, 2)
        The row's flow (:func:`_shorth` of its reliable pixels).
    weight : ndarray of shape (m,)
        Fraction of the row's pixels that were reliable.
    """
    h, w = ok.shape
    count = ok.sum(axis=1)
    use = count >= max(8, 0.15 * w)
    if not use.any():
        return np.zeros(0), np.zeros((0, 2)), np.zeros(0)
    # The shorth sorts every row: a hundred and more samples per row are plenty.
    stride = max(1, w // 160)
    vals = np.where(ok[use, ::stride, None], flow[use, ::stride], np.nan)
    return np.flatnonzero(use).astype(np.float64), _shorth(vals), count[use] / w


def half_row_flows(flow: np.ndarray, ok: np.ndarray
                   ) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """Rows and row flows (:func:`row_flows`) of the left and of the right half."""
    half = flow.shape[1] // 2
    left, right = (row_flows(flow[:, c], ok[:, c])[:2]
                   for c in (slice(0, half), slice(half, None)))
    return left, right


def invert_flow(flow: np.ndarray, iterations: int = 3) -> np.ndarray:
    """Invert a dense flow by the fixed point ``G(q) = -F(q + G(q))``.

    If ``F`` carries the pixels of ``b`` to ``a`` (``b(s) ~ a(s + F(s))``), ``G`` carries
    those of ``a`` back to ``b``. The flow is sampled bilinearly at the current estimate;
    the iteration converges wherever the flow does not fold. Where content of ``a`` has no
    counterpart in ``b`` (disocclusion) the result is the flow of the surroundings.

    Parameters
    ----------
    flow : ndarray of shape (h, w, 2), float32
    iterations : int

    Returns
    -------
    ndarray of shape (h, w, 2), float32

    Examples
    --------
    >>> f = np.zeros((20, 30, 2), np.float32); f[..., 0] = 2.5
    >>> bool(np.allclose(invert_flow(f)[..., 0], -2.5))
    True
    """
    h, w = flow.shape[:2]
    gx, gy = pixel_grid(h, w)
    inv = -flow
    for _ in range(iterations):
        inv = -cv2.remap(flow, gx + inv[..., 0], gy + inv[..., 1], cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_REPLICATE)
    return inv


def _patch_cost(cur: np.ndarray, other: np.ndarray, gx: np.ndarray, gy: np.ndarray,
                flow: np.ndarray, window: int) -> np.ndarray:
    """Mean absolute difference of ``cur`` and ``other`` moved by ``flow``, over square patches.

    ``gx, gy`` are the pixel coordinates of ``cur`` in ``other`` without motion (a crop's
    offset included).
    """
    warped = cv2.remap(other, gx + flow[..., 0], gy + flow[..., 1], cv2.INTER_LINEAR,
                       borderMode=cv2.BORDER_REPLICATE)
    return cv2.boxFilter(cv2.absdiff(warped, cur), -1, (window, window))


def refine_motion_edges(cur: np.ndarray, prev: np.ndarray, flow: np.ndarray,
                        spread: float = 2.0, radii: tuple[int, ...] = (3, 8),
                        window: int = 5) -> np.ndarray:
    """Give pixels near a motion boundary the flow of the side they belong to.

    DIS smooths the flow across the edge of a nearer layer or a moving object, so the
    pixels of the background next to it move partly with it (and the other way round).
    Where the flow varies by more than ``spread`` px within 9x9 pixels, each pixel may
    take the flow found ``radii`` px away in one of eight directions, if that flow
    matches the previous frame better over a ``window`` x ``window`` patch (sum of
    absolute differences of the warped previous frame). Measured
    (``benchmarks/synthetic.py``, 320x240): two-depth parallax 0.022x -> 0.014x of the
    uncorrected error, a moving object's background 0.019x -> 0.012x; research pairs
    Fastec 28.76 -> 28.74 dB, Carla 31.48 -> 31.49 dB (with five DIS refinement
    iterations: 0.019x -> 0.012x, 0.016x -> 0.011x, 28.78 -> 28.73, 31.37 -> 31.45 dB).
    A 3x3 patch was better on the
    suite (0.010x, 0.009x) and worse on the pairs (28.70, 31.39); radii 3, 6 and 10 px
    scored as 3 and 8 at 1.7x the cost. Cost: nothing where there are no boundaries,
    22 ms on a 480x270 copy with boundaries everywhere (synthetic); the Carla town
    sequence (640x448, parallax throughout) went from 0.15 to 0.20 s a frame.

    Parameters
    ----------
    cur, prev : ndarray of shape (h, w), float32
        The frame and the one the flow points to.
    flow : ndarray of shape (h, w, 2), float32
        Flow from ``cur`` to ``prev`` (``cur(s) ~ prev(s + flow(s))``).

    Returns
    -------
    ndarray of shape (h, w, 2), float32
    """
    kernel = np.ones((9, 9), np.uint8)
    edge = np.zeros(flow.shape[:2], dtype=bool)
    for k in range(2):
        f = flow[..., k]
        edge |= (cv2.dilate(f, kernel) - cv2.erode(f, kernel)) > spread
    if not edge.any():
        return flow
    # Work on the rows and columns around the boundaries only.
    pad = max(radii) + window
    ys, xs = np.nonzero(edge)
    h, w = flow.shape[:2]
    y0, y1 = max(0, ys.min() - pad), min(h, ys.max() + pad + 1)
    x0, x1 = max(0, xs.min() - pad), min(w, xs.max() + pad + 1)
    crop = (slice(y0, y1), slice(x0, x1))
    fl, here, near = flow[crop], cur[crop], edge[crop]
    ch, cw = near.shape
    gx, gy = pixel_grid(ch, cw, y0, x0)

    def cost(f: np.ndarray) -> np.ndarray:
        return _patch_cost(here, prev, gx, gy, f, window)

    # Candidate 0 is the pixel's own flow; ties keep it.
    offsets = [(0, 0)] + [(dx * r, dy * r) for r in radii
                          for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1),
                                         (1, 1), (1, -1), (-1, 1), (-1, -1))]
    padded = cv2.copyMakeBorder(fl, pad, pad, pad, pad, cv2.BORDER_REPLICATE)
    best_cost = cost(fl)
    pick = np.zeros((ch, cw), np.int64)
    for i, (ox, oy) in enumerate(offsets[1:], start=1):  # one candidate held at a time
        c = cost(padded[pad + oy:pad + oy + ch, pad + ox:pad + ox + cw])
        better = near & (c < best_cost)
        np.copyto(best_cost, c, where=better)
        pick[better] = i
    off = np.array(offsets)[pick]  # (ch, cw, 2)
    src_y = np.clip(np.arange(ch)[:, None] + off[..., 1], 0, ch - 1)
    src_x = np.clip(np.arange(cw)[None, :] + off[..., 0], 0, cw - 1)
    best = fl[src_y, src_x]
    out = flow.copy()
    out[crop] = best
    return out


def flow_pair(prev: np.ndarray, cur: np.ndarray, config: DenseConfig, max_width: int = 0,
              two_way: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Flows between two frames both ways, each with its forward-backward check.

    The flow from ``cur`` to ``prev`` is computed (DIS); the other way is its inverse
    (:func:`invert_flow`), which costs a fraction of a second flow and scored as well on
    the research pairs (Fastec 28.1 vs 27.9 dB, Carla 30.4 vs 30.5 dB). With
    ``two_way`` the other way is a second DIS flow: an independent check that rejects
    more wrong flow (the readout estimate needs it; it is twice the cost).

    Returns
    -------
    bwd, bwd_ok : ndarray
        Flow from ``cur`` to ``prev`` and its reliable pixels.
    fwd, fwd_ok : ndarray
        Flow from ``prev`` to ``cur`` and its reliable pixels.
    """
    refinement = config.refinement if config.flow_preset == "medium" else None
    bwd = optical_flow(cur, prev, config.flow_preset, max_width, config.finest_scale,
                       refinement)
    if config.edge_refine:
        bwd = refine_motion_edges(np.asarray(cur, np.float32), np.asarray(prev, np.float32),
                                  bwd)
    fwd = (optical_flow(prev, cur, config.flow_preset, max_width, config.finest_scale,
                        refinement)
           if two_way else invert_flow(bwd))
    return (bwd, _consistent(bwd, fwd, config.consistency),
            fwd, _consistent(fwd, bwd, config.consistency))


def _fill_unreliable(resid: np.ndarray, ok: np.ndarray, sigma: float) -> np.ndarray:
    """Replace residuals of unreliable pixels by a normalised Gaussian average of reliable ones."""
    if ok.all() or not ok.any() or sigma <= 0:
        return resid if ok.any() else np.zeros_like(resid)
    # The average is smooth: blur at a quarter of the resolution, then interpolate back.
    h, w_ = ok.shape
    small = (max(1, w_ // 4), max(1, h // 4))
    okf = cv2.resize(ok.astype(np.float32), small, interpolation=cv2.INTER_AREA)
    numf = cv2.resize(resid * ok[..., None], small, interpolation=cv2.INTER_AREA)
    w = cv2.resize(cv2.GaussianBlur(okf, (0, 0), sigma / 4), (w_, h))
    num = cv2.resize(cv2.GaussianBlur(numf, (0, 0), sigma / 4), (w_, h))
    avg = num / np.maximum(w, 1e-3)[..., None]
    avg[w <= 1e-3] = 0.0
    np.copyto(avg, resid, where=ok[..., None])
    return avg


def _smooth_field(field: np.ndarray) -> np.ndarray:
    """5x5 median of each component (isolated wrong flow vectors)."""
    for k in range(2):
        field[..., k] = cv2.medianBlur(np.ascontiguousarray(field[..., k]), 5)
    return field


def _projective_flow(coef: np.ndarray, x: np.ndarray, y: np.ndarray, size: tuple[int, int]
                     ) -> np.ndarray:
    """Evaluate the eight-parameter projective flow (planar scene, camera rotation) at x, y.

    ``u = a1 + a2 x + a3 y + a7 x^2 + a8 x y``, ``v = a4 + a5 x + a6 y + a7 x y + a8 y^2``
    with ``x, y`` centred on the image of ``size`` (h, w) and scaled by its larger side.
    It is linear in ``coef``: evaluated with unit vectors it gives the model's columns.

    Returns
    -------
    ndarray of shape ``x.shape + (2,)``
    """
    h, w = size
    scale = np.float32(1.0 / max(h, w))
    x = (x - np.float32(0.5 * w)) * scale
    y = (y - np.float32(0.5 * h)) * scale
    a1, a2, a3, a4, a5, a6, a7, a8 = np.asarray(coef, dtype=np.float32)
    quad = a7 * x + a8 * y
    return np.stack([a1 + a2 * x + a3 * y + quad * x, a4 + a5 * x + a6 * y + quad * y],
                    axis=-1)


def _fit_projective(values: np.ndarray, ok: np.ndarray, x: np.ndarray, y: np.ndarray,
                    stride: int = 8) -> np.ndarray | None:
    """Robust fit of the projective flow (:func:`_projective_flow`) to ``values`` at ``(x, y)``.

    Iteratively reweighted least squares (four rounds, residuals beyond 1.5 times their
    median down-weighted: independently moving objects and parallax are outliers) over
    every ``stride``-th reliable sample of the grid.

    Parameters
    ----------
    values : ndarray of shape (h, w, 2)
        Vectors to fit (a flow, a velocity).
    ok : ndarray of bool, shape (h, w)
        Samples that may be used.
    x, y : ndarray of shape (h, w)
        Where each vector belongs.
    stride : int
        Sampling step of the grid.

    Returns
    -------
    ndarray of shape (8,) or None
        The coefficients; None with fewer than 32 usable samples.
    """
    h, w = values.shape[:2]
    sub = (slice(None, None, stride), slice(None, None, stride))
    use = ok[sub].ravel()
    n = int(use.sum())
    if n < 32:
        return None
    # The model's columns (see :func:`_projective_flow`) at the samples, in its units.
    scale = 1.0 / max(h, w)
    xs = (x[sub].ravel()[use].astype(np.float64) - 0.5 * w) * scale
    ys = (y[sub].ravel()[use].astype(np.float64) - 0.5 * h) * scale
    one, zero = np.ones(n), np.zeros(n)
    a = np.stack([np.stack([one, xs, ys, zero, zero, zero, xs * xs, xs * ys], axis=1),
                  np.stack([zero, zero, zero, one, xs, ys, xs * ys, ys * ys], axis=1)],
                 axis=1).reshape(2 * n, 8)  # rows: x then y of each sample
    target = values[sub].reshape(-1, 2)[use].astype(np.float64).ravel()
    weight = np.ones(n)
    with _BLAS.limit(limits=1, user_api="blas"):
        for _ in range(4):
            aw = (a * np.repeat(weight ** 2, 2)[:, None]).T
            coef = np.linalg.solve(aw @ a + 1e-12 * np.eye(8), aw @ target)
            r = (a @ coef - target).reshape(n, 2)
            r = np.hypot(r[:, 0], r[:, 1])
            weight = 1.0 / np.maximum(r / (1.5 * np.median(r) + 1e-3), 1.0)
    return coef


def _advected_velocity(vel: np.ndarray, ok: np.ndarray, flow: np.ndarray,
                       ahead: np.ndarray, stride: int = 8) -> np.ndarray:
    """Each pixel's velocity, moved along its path ahead through the smooth flow field.

    ``vel`` is each pixel's mean velocity over its measured path to the neighbour frame
    (``flow``), so it belongs half-way along that path, at ``s + flow(s) / 2``; the
    pixel moves on by ``ahead`` to the reference time and meets the velocity half-way
    there, at ``s + ahead / 2`` (midpoint rule). The flow of a camera rotating or moving
    over a plane at a steady rate is a fixed field over the image, the projective flow
    (:func:`_projective_flow`): fitted (robustly, to the reliable pixels) and used for
    the change of velocity between the two places. What is left (the depth of each
    point) travels with the point. A constant velocity per pixel misses the acceleration
    a point sees moving through a zoom or a perspective; the residual of its fit would
    carry objects' edges through the frame.

    Measured on the research pairs (``benchmarks/pairs.py``, two frames, extrapolating
    half a frame): Fastec 28.32 -> 28.78 dB, Carla 31.19 -> 31.37 dB. An affine field gave
    28.72 / 31.26; a quadratic 28.70 / 31.37; the full per-pixel field (a stationary
    velocity field) 28.06 / 30.99.
    """
    h, w = vel.shape[:2]
    gx, gy = pixel_grid(h, w)
    mid_x, mid_y = gx + 0.5 * flow[..., 0], gy + 0.5 * flow[..., 1]
    coef = _fit_projective(vel, ok, mid_x, mid_y, stride)
    if coef is None:
        return vel
    return (vel + _projective_flow(coef, gx + 0.5 * ahead[..., 0], gy + 0.5 * ahead[..., 1],
                                   (h, w))
            - _projective_flow(coef, mid_x, mid_y, (h, w)))


def snap_to_global(cur: np.ndarray, other: np.ndarray, flow: np.ndarray, ok: np.ndarray,
                   window: int = 9) -> np.ndarray:
    """Give pixels the frame's global motion where it explains them as well as their own flow.

    Dense flow is smoothed across motion boundaries (the background next to a moving
    object or a nearer layer moves partly with it) and is noisy where the scene has little
    structure. The frame's global motion -- the projective flow (:func:`_projective_flow`)
    fitted robustly to the reliable pixels: camera rotation, a plane, the dominant layer --
    replaces a pixel's own flow where it matches the other frame at least as well over a
    ``window`` x ``window`` patch (sum of absolute differences). Pixels of independently
    moving objects and of other layers keep their flow: the global motion does not match
    them. Measured (``benchmarks/synthetic.py``, 320x240, dense method, error relative to
    uncorrected, without -> with): moving object's background 0.0191x -> 0.0146x, the
    same pan without the object 0.0046x -> 0.0013x, two-depth parallax 0.021x -> 0.018x,
    pan 0.010x -> 0.006x, hand shake 0.046x -> 0.042x, PSNR within 0.02 dB; research
    pairs (``benchmarks/pairs.py``) Fastec 28.79 -> 28.78 dB, Carla 31.56 -> 31.57 dB. A
    5 px window scored better on the suite (0.012x, 0.0009x, 0.015x) and worse on the
    pairs (28.77 / 31.53); with it, asking the global motion to be better by a quarter of a
    grey level scored worse on the suite (0.014x, 0.0017x, 0.017x) at the same pairs
    figures; the camera's row model as the candidate instead cost the pairs 0.4 dB.

    Parameters
    ----------
    cur, other : ndarray of shape (h, w), float32
        The frame and the neighbour the flow points to.
    flow : ndarray of shape (h, w, 2), float32
        Flow from ``cur`` to ``other`` (``cur(s) ~ other(s + flow(s))``).
    ok : ndarray of bool, shape (h, w)
        Pixels whose flow is reliable (the fit's samples).
    window : int
        Side of the patch compared (px).

    Returns
    -------
    ndarray of shape (h, w, 2), float32
    """
    h, w = flow.shape[:2]
    gx, gy = pixel_grid(h, w)
    coef = _fit_projective(flow, ok, gx, gy)
    if coef is None:
        return flow
    glob = _projective_flow(coef, gx, gy, (h, w))

    better = (_patch_cost(cur, other, gx, gy, glob, window)
              <= _patch_cost(cur, other, gx, gy, flow, window))
    return np.where(better[..., None], glob, flow)


@dataclass
class _Frame:
    index: int
    start: float
    image: np.ndarray
    bwd: np.ndarray | None = None  # flow to the previous frame
    fwd: np.ndarray | None = None  # flow to the next frame
    bwd_ok: np.ndarray | None = None
    fwd_ok: np.ndarray | None = None

    @property
    def contrast(self) -> float:
        """Standard deviation of the grey levels (a fade from black starts near 0)."""
        return float(cv2.meanStdDev(self.image)[1][0, 0])


class DenseMethod:
    """Streaming dense method: returns each frame's motion ``window`` frames later.

    Parameters
    ----------
    timing : SensorTiming
        Readout and reference (frames already in top-bottom orientation).
    config : DenseConfig
        Settings.
    """

    def __init__(self, timing: SensorTiming, config: DenseConfig = DenseConfig()) -> None:
        self.timing = timing
        self.config = config
        self._frames: deque[_Frame] = deque()
        self._equations: deque[tuple[int, tuple]] = deque()  # (frame, its pair's rows)
        self._decided = not config.detect_vibration
        self._halves: list[tuple[tuple[np.ndarray, np.ndarray], ...]] = []
        self._note = ""  # added to every frame's note once vibration is detected
        self._freqs: tuple[int, np.ndarray] | None = None  # (last pair, sinusoids' freqs)
        self._count = 0
        self._next_out = 0
        self._full: tuple[int, int] = (0, 0)

    def push(self, frame: np.ndarray, start: float) -> list[FrameMotion]:
        """Add the next frame (grey, 0-255, top-bottom) starting at time ``start``."""
        img = np.asarray(frame)
        if img.dtype not in (np.uint8, np.float32):
            img = img.astype(np.float32)
        self._full = (img.shape[0], img.shape[1])
        ww = self.config.work_width
        if ww and img.shape[1] > ww:
            size = (ww, max(8, round(img.shape[0] * ww / img.shape[1])))
            img = cv2.resize(img, size, interpolation=cv2.INTER_AREA)
        cur = _Frame(self._count, float(start), img.astype(np.float32))
        self._count += 1
        if self._frames:
            prev = self._frames[-1]
            if self.config.per_pixel:
                cur.bwd, cur.bwd_ok, prev.fwd, prev.fwd_ok = flow_pair(prev.image, cur.image,
                                                                       self.config)
            else:  # rows only: one flow, its robust row summary rejects the outliers
                cur.bwd = optical_flow(cur.image, prev.image, self.config.flow_preset, 0,
                                       self.config.finest_scale)
                cur.bwd_ok = landing(cur.bwd)[2]  # lands inside the frame
            self._equations.append((cur.index, self._row_equations(prev, cur)))
            if not self._decided and min(prev.contrast, cur.contrast) >= _PROBE_CONTRAST:
                # Rows of each half, for the vibration test (frames too flat to give
                # flow, as in a fade from black, would wobble with their noise).
                self._halves.append(half_row_flows(cur.bwd, cur.bwd_ok))
            if not self.config.per_pixel:
                cur.bwd = cur.bwd_ok = None  # nothing per pixel is needed later
        self._frames.append(cur)
        return self._ready(final=False)

    def flush(self) -> list[FrameMotion]:
        """Return the motion of the frames still pending at the end of the clip."""
        return self._ready(final=True)

    def _row_equations(self, prev: _Frame, cur: _Frame) -> tuple:
        """Row flows of ``cur`` -> equations ``c(t_a) - c(t_b) + u(y)(t_a - t_b) = delta``."""
        assert cur.bwd is not None and cur.bwd_ok is not None
        h = cur.image.shape[0]
        rho = self.timing.readout
        y, med, wgt = row_flows(cur.bwd, cur.bwd_ok)
        t_a = cur.start + rho * y / h
        t_b = prev.start + rho * (y + med[:, 1]) / h
        return t_a, t_b, y / max(h - 1, 1), -med, wgt

    def _pairs(self, n: int, final: bool) -> tuple[int, int]:
        """First and last pair (by later frame) of frame ``n``'s window.

        ``history`` pairs before and ``window`` after; near the ends of the clip the window
        keeps its length and shifts inwards, so the first and last frames are solved with
        as much context as the others.
        """
        span = self.config.history + self.config.window
        lo = max(1, n - self.config.history + 1)
        hi = lo + span - 1
        if final:
            hi = min(hi, self._count - 1)
            lo = max(1, hi - span + 1)
        return lo, hi

    def _decide(self) -> None:
        """Switch to :data:`VIBRATION` if the probed pairs wobble (decided once)."""
        self._decided = True
        if not self._frames:
            return
        halves, self._halves = self._halves, []
        # (a clip shorter than the probe gains little from it)
        wobble = detect_vibration(halves, self._frames[0].image.shape[0], self.config.probe)
        if wobble is not None:
            self.config = dataclasses.replace(self.config, **VIBRATION)
            self._note = (f"vibration detected (wobble {100 * wobble:.2f}% of the height): "
                          "one-second window")

    def _ready(self, final: bool) -> list[FrameMotion]:
        out: list[FrameMotion] = []
        if not self._decided:
            probed = len(self._halves) >= self.config.probe
            if not final and not probed and self._count - 1 < _PROBE_WAIT * self.config.probe:
                return out
            self._decide()
        while self._next_out < self._count and (
                final or self._count - 1 >= self._pairs(self._next_out, False)[1]):
            n = self._next_out
            fr = next(f for f in self._frames if f.index == n)
            out.append(self._emit(fr, self._pairs(n, final)))
            self._next_out += 1
            while self._frames and self._frames[0].index < n:  # n - 1 stays for n + 1
                self._frames.popleft()
            span = self.config.history + self.config.window
            while (len(self._equations) > span
                   and self._equations[0][0] < self._pairs(n + 1, False)[0]):
                self._equations.popleft()
        return out

    def _camera(self, pairs: tuple[int, int]) -> CameraSolution | None:
        eqs = [rows for index, rows in self._equations
               if pairs[0] <= index <= pairs[1] and len(rows[0])]
        if not eqs:
            return None
        t_a, t_b, rows, delta, wgt = (np.concatenate([e[i] for e in eqs]) for i in range(5))
        step = self.timing.readout / self.config.grid
        smoothness = self.config.smoothness
        if len(eqs) == 1:
            smoothness = max(smoothness, self.config.pair_smoothness)
        if not self.config.sinusoids or len(eqs) < 3:
            return solve_camera_trajectory(t_a, t_b, rows, delta, wgt, step, smoothness)
        # A vibration's frequencies hold for a while: picked again every 8 frames, from
        # what the smooth trajectory leaves of every 4th row equation (the choice costs
        # far more than the solve).
        if self._freqs is None or pairs[1] - self._freqs[0] >= 8:
            sub = slice(None, None, 4)
            sol = solve_camera_trajectory(t_a, t_b, rows, delta, wgt, step, smoothness)
            left = delta[sub] - sol.differences(t_a[sub], t_b[sub], rows[sub])
            picked, _ = sinusoid_pursuit(t_a[sub] - sol.t0, t_b[sub] - sol.t0, left, wgt[sub],
                                         np.zeros((t_a[sub].size, 0)), self.config.sinusoids,
                                         ridge=_SINE_RIDGE)
            self._freqs = (pairs[1], picked)
        return solve_camera_trajectory(t_a, t_b, rows, delta, wgt, step, smoothness,
                                       freqs=self._freqs[1])

    def _emit(self, fr: _Frame, pairs: tuple[int, int]) -> FrameMotion:
        """Frame ``fr``'s motion from the camera solve over ``pairs`` and its own flows."""
        h, w = fr.image.shape
        t_rows = self.timing.row_times(h, fr.start)
        t_ref = self.timing.reference_time(h, fr.start)
        cam = self._camera(pairs)
        if cam is None:
            z = np.zeros((self._full[0], 2))
            return FrameMotion(fr.index, fr.start, z, z, ok=False,
                               note="no reliable motion: frame left as is")
        t0, step, c, u = cam.t0, cam.step, cam.c, cam.u
        # Times relative to the frame's start, so float32 keeps sub-row precision.
        grid_t = t0 - fr.start + step * np.arange(c.shape[0])
        t_rows = t_rows - fr.start
        t_ref = t_ref - fr.start

        def c_at(t: np.ndarray) -> np.ndarray:
            return np.stack([np.interp(t, grid_t, c[:, 0]), np.interp(t, grid_t, c[:, 1])],
                            axis=-1).astype(np.float32)

        c_img = c.astype(np.float32)[None]
        zero_map = np.zeros((h, w), np.float32)

        def c_at_pixels(t: np.ndarray) -> np.ndarray:
            """``c`` at every pixel's time (uniform grid: one vectorised lookup)."""
            idx = (t - np.float32(grid_t[0])) * np.float32(1.0 / step)
            return cv2.remap(c_img, idx, zero_map, cv2.INTER_LINEAR,
                             borderMode=cv2.BORDER_REPLICATE)

        cam_rows = c_at(t_rows)
        cam_disp = cam_rows - c_at(np.array([t_ref]))[0]
        velocity = np.gradient(cam_rows.astype(np.float64), t_rows, axis=0) if h > 1 else (
            np.zeros((h, 2)))
        u_rows = np.zeros((h, 2))
        if u.shape[0]:
            knots = np.linspace(0, 1, u.shape[0])
            frac_rows = np.arange(h) / max(h - 1, 1)
            u_rows = np.stack([np.interp(frac_rows, knots, u[:, k]) for k in range(2)], axis=1)
        velocity = velocity + u_rows
        full_h, full_w = self._full
        scale = np.array([full_w / w, full_h / h], dtype=np.float32)
        rows_full = (np.arange(full_h) + 0.5) * h / full_h - 0.5

        def to_full_rows(values: np.ndarray) -> np.ndarray:
            return np.stack([np.interp(rows_full, np.arange(h), values[:, k])
                             for k in range(2)], axis=1) * scale

        if not self.config.per_pixel:
            # Eq. 26 per scanline: the camera's displacement plus the row velocity's.
            disp_rows = cam_disp + u_rows * (t_rows - t_ref)[:, None]
            return FrameMotion(fr.index, fr.start, to_full_rows(disp_rows),
                               to_full_rows(velocity), ok=True, note=self._note)
        field_resid, fallback = self._residual(fr, t_rows, t_ref, cam_rows, cam_disp,
                                               c_at_pixels)
        field = cam_disp[:, None, :] - field_resid
        frac = float(fallback.mean())
        note = f"{100 * frac:.0f}% of pixels on the camera model (flow unreliable)" if (
            frac > 0.05) else ""
        note = "; ".join(n for n in (self._note, note) if n)
        # Back to the full frame: per-row values per full row, field in full-frame pixels.
        disp = to_full_rows(np.median(field[:, ::4], axis=1))  # a summary: every 4th is plenty
        field *= scale
        neighbours = tuple((offset, flow) for offset, flow in ((-1, fr.bwd), (1, fr.fwd))
                           if flow is not None)
        return FrameMotion(fr.index, fr.start, disp, to_full_rows(velocity), ok=True,
                           note=note, fallback=frac, field=field, neighbours=neighbours)

    def _residual(self, fr: _Frame, t_rows: np.ndarray, t_ref: float, cam_rows: np.ndarray,
                  cam_disp: np.ndarray, c_at_pixels: Callable[[np.ndarray], np.ndarray]
                  ) -> tuple[np.ndarray, np.ndarray]:
        """Each pixel's motion beyond the camera's, carried to the reference time.

        Returns
        -------
        field_resid : ndarray of shape (h, w, 2)
            Quadratic through the residual flows to both neighbours. With one neighbour
            (the ends of a clip, a frame pair) the pixel's mean velocity over its measured
            way, moved along its way to the reference time through the smooth part of the
            flow field (:func:`_advected_velocity`; with ``advect`` off, the straight
            line through the one residual). Unreliable pixels take their reliable
            neighbours' (Gaussian average), then a 5x5 median.
        fallback : ndarray of bool, shape (h, w)
            Pixels whose flow was unreliable on both sides.
        """
        h, w = fr.image.shape
        rho = self.timing.readout
        ys = np.arange(h, dtype=np.float32)[:, None]
        t_s = np.broadcast_to(t_rows.astype(np.float32)[:, None], (h, w))
        c_s = cam_rows[:, None, :]
        sides = []
        neighbours = {f.index: f for f in self._frames}
        for flow, ok, other in ((fr.bwd, fr.bwd_ok, neighbours.get(fr.index - 1)),
                                (fr.fwd, fr.fwd_ok, neighbours.get(fr.index + 1))):
            if flow is None or ok is None or other is None:
                continue
            if self.config.snap_window:
                flow = snap_to_global(fr.image, other.image, flow, ok, self.config.snap_window)
            t_o = np.float32(other.start - fr.start) + np.float32(rho / h) * (ys + flow[..., 1])
            resid = flow - (c_at_pixels(t_o) - c_s)
            sides.append((t_o, resid, ok, flow))
        tr = np.float32(t_ref)
        if len(sides) == 1 and self.config.advect:
            # One neighbour: the pixel's velocity, carried along its way to t_ref.
            t_o, r, ok, flow = sides[0]
            vel = _smooth_field(_fill_unreliable(r / (t_o - t_s)[..., None], ok,
                                                 self.config.fill_sigma))
            dt = (tr - t_s)[..., None]
            ahead = dt * vel - cam_disp[:, None, :]
            return dt * _advected_velocity(vel, ok, flow, ahead), ~ok
        field_resid = np.zeros((h, w, 2), np.float32)
        fallback = np.ones((h, w), dtype=bool)
        if len(sides) == 2:
            (ta, ra, oka, _), (tb, rb, okb, _) = sides
            both = oka & okb
            # Quadratic through (ta, ra), (t_s, 0), (tb, rb) evaluated at t_ref.
            la = ((tr - t_s) * (tr - tb)) / ((ta - t_s) * (ta - tb))
            lb = ((tr - t_s) * (tr - ta)) / ((tb - t_s) * (tb - ta))
            quad = la[..., None] * ra + lb[..., None] * rb
            np.copyto(field_resid, quad, where=both[..., None])
            fallback &= ~both
        for t_o, r, ok, _ in sides:  # one side only: the straight line through it
            only = ok & fallback
            lin = ((tr - t_s) / (t_o - t_s))[..., None] * r
            np.copyto(field_resid, lin, where=only[..., None])
            fallback &= ~only
        field_resid = _smooth_field(_fill_unreliable(field_resid, ~fallback,
                                                     self.config.fill_sigma))
        return field_resid, fallback
