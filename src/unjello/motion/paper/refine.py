"""Constrained local motion refinement (paper Sec. V.C, eq. 20-25).

Liang, Chang & Chen (2008), Sec. V.C. The Bezier velocity of Sec. V.B is refined
around points of the current frame: a point whose predicted correspondence in the
previous frame falls outside that frame is an outlier (eq. 20-21, with safety margins
eq. 22-23); around the others a local block match finds the local motion ``l`` (eq. 24),
which gives a refined velocity sample (eq. 25). Samples whose match residual is below a
threshold are added as constraints on the Bezier curve, and the velocity is re-fitted
from the four closest samples; the whole is iterated (the paper: three times).

Generalisation and sign
-----------------------
In our sign convention (:mod:`unjello.timing`) the local vector ``l`` of a block at
``s1`` in frame ``n`` is ``s1 - s2`` with ``s2`` its match in frame ``n - 1``. ``s1`` is
imaged at ``t_n + rho s1_y / h`` and ``s2`` at ``t_{n-1} + rho s2_y / h``, so by eq. 2
and the mean value theorem (eq. 10)

    l = v(tau) (dt + rho l_y / h),        dt = t_n - t_{n-1},

which gives the refined velocity (eq. 25, the paper's ``T - l_y`` being the same
interval written for vectors taken from frame ``n`` to ``n - 1``)

    v'(tau) = l / (dt + rho l_y / h),

placed at the midpoint ``tau`` of the interval (see :mod:`unjello.motion.paper.velocity`).
Conversely a velocity ``v`` predicts ``l_y = v_y dt / (1 - rho v_y / h)`` and
``l_x = v_x (dt + rho l_y / h)``; eq. 22-23 then read
``eps_x <= s_x - l_x <= w - eps_x`` and ``eps_y <= s_y - l_y <= h - eps_y``.
The search and the samples: departures from the paper, and why
---------------------------------------------------------------
- The paper sizes each region's search range by eq. 22-23, up to 100 px. Here a block
  is searched in a window of +/- ``radius`` px around the motion the curve predicts
  and, where that prediction and the frame's global motion ``g(n)`` (Sec. V.A) differ
  by more than the window, in a second window around ``g(n)``; the better match is
  kept. Between them the two windows hold the true motion whenever the curve or
  ``g(n)`` is within ``radius`` of it, at 2 x 13^2 candidates per block instead of
  201^2 (the exhaustive +/-160 px search has already been done once, in Sec. V.A).
  Around a wrong prediction alone, the right matches fall on the window's edge and
  are rejected, and the prediction can never be corrected (a pan from rest).
- The paper estimates a region's local motion "in a way similar to global motion
  estimation" (Sec. V.C), i.e. by the peak of the 2-D histogram of its blocks' vectors.
  Here a region is a block row (all of its blocks are imaged at nearly the same time,
  and a velocity sample belongs to a time): its sample is the median of the blocks
  within one pixel of the peak of its low-pass filtered histogram
  (:func:`~unjello.motion.paper.global_motion.histogram_peak`, as for ``g(n)``), and only
  when they are at least half of the row's tested blocks. A few false matches of a
  row whose true motion was not found must not make a sample: the cubic through four
  samples 0.03 frame apart turns their sub-pixel differences into hundreds of px.
- The paper adds the refined samples to the curve's constraints "in addition to the
  four constraints (15)-(18)". Here a frame pair's local samples *replace* its global
  sample ``g(n)`` (:class:`~unjello.motion.paper.method.PaperMethod`). ``g(n)`` is the mean
  velocity over a whole frame interval; among local samples a few hundredths of a frame
  apart, its small difference from the instantaneous velocity bends the cubic through
  the four nearest samples. Measured (``benchmarks/paper.py``, pans from rest): with
  ``g(n)`` kept beside the local samples, 720p horizontal at readout 0.8 0.006x ->
  0.031x of the uncorrected error, diagonal at 0.6 0.011x -> 0.026x; no case improved.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from .global_motion import histogram_peak, subpixel_offsets

__all__ = ["RefineConfig", "LocalMatches", "predict_local_motion", "inside_constraints",
           "local_block_match", "better_matches", "refined_velocity", "row_samples"]


@dataclass(frozen=True)
class RefineConfig:
    """Settings of the local refinement (Sec. V.C and VI).

    Parameters
    ----------
    block : int
        Block size of the local matching.
    radius : int
        Search radius around the predicted local motion, px.
    iterations : int
        Refinement / re-fit rounds (the paper: 3).
    max_residual : float
        Largest mean absolute difference per pixel (0-255 scale) of an accepted match.
    min_std : float
        Blocks flatter than this (grey-level standard deviation) are not matched.
    min_blocks : int
        Accepted blocks a block row needs to give a velocity sample.
    """

    block: int = 16
    radius: int = 6
    iterations: int = 3
    max_residual: float = 12.0
    min_std: float = 4.0
    min_blocks: int = 3


@dataclass(frozen=True)
class LocalMatches:
    """Local motion of blocks (eq. 24).

    Attributes
    ----------
    centers : ndarray of shape (N, 2)
        ``(x, y)`` of the block centres ``s1`` in frame ``n``.
    motion : ndarray of shape (N, 2)
        Sub-pixel local motion ``l = s1 - s2``.
    residual : ndarray of shape (N,)
        Mean absolute difference per pixel at the match.
    accepted : ndarray of bool, shape (N,)
        Inside the constraints, below the residual threshold, not on the window's edge.
    """

    centers: np.ndarray
    motion: np.ndarray
    residual: np.ndarray
    accepted: np.ndarray


def predict_local_motion(velocity: np.ndarray, dt: float, readout: float, height: int
                         ) -> np.ndarray:
    """Local motion ``l`` predicted by a velocity (inverse of eq. 25).

    Parameters
    ----------
    velocity : ndarray of shape (N, 2)
        Velocity at the blocks' scanline times.
    dt : float
        Time between the two frames' starts.
    readout : float
        Readout ratio ``rho``.
    height : int
        Frame height ``h``.

    Returns
    -------
    ndarray of shape (N, 2)

    Examples
    --------
    >>> predict_local_motion(np.array([[2.0, 10.0]]), 1.0, 1.0, 100).round(4).tolist()
    [[2.2222, 11.1111]]
    """
    v = np.asarray(velocity, dtype=np.float64).reshape(-1, 2)
    k = readout / height
    ly = v[:, 1] * dt / np.maximum(1.0 - k * v[:, 1], 1e-6)
    lx = v[:, 0] * (dt + k * ly)
    return np.stack([lx, ly], axis=1)


def inside_constraints(centers: np.ndarray, local_motion: np.ndarray, size: tuple[int, int],
                       margin: tuple[float, float]) -> np.ndarray:
    """Outlier test of eq. 22-23: the correspondence ``s - l`` must lie inside the frame.

    Parameters
    ----------
    centers : ndarray of shape (N, 2)
        Points ``s`` of the current frame.
    local_motion : ndarray of shape (N, 2)
        Predicted ``l``.
    size : tuple of int
        ``(w, h)``.
    margin : tuple of float
        Safety margins ``(eps_x, eps_y)``.

    Returns
    -------
    ndarray of bool, shape (N,)
        True where eq. 22 and 23 hold.
    """
    w, h = size
    s2 = centers - local_motion
    return ((s2[:, 0] >= margin[0]) & (s2[:, 0] <= w - margin[0])
            & (s2[:, 1] >= margin[1]) & (s2[:, 1] <= h - margin[1]))


def local_block_match(prev: np.ndarray, cur: np.ndarray, centers: np.ndarray,
                      predicted: np.ndarray, config: RefineConfig = RefineConfig()
                      ) -> LocalMatches:
    """Exhaustive SAD block matching in a small window around predicted motions (eq. 24).

    Parameters
    ----------
    prev, cur : ndarray of shape (H, W), float32, 0-255
        Previous and current frame.
    centers : ndarray of shape (N, 2)
        Block centres in ``cur``.
    predicted : ndarray of shape (N, 2)
        Predicted local motion ``l`` of each block.
    config : RefineConfig

    Returns
    -------
    LocalMatches
        ``accepted`` is False for blocks whose window leaves the frame, flat blocks,
        matches on the window's edge and residuals above the threshold.
    """
    b, r = config.block, config.radius
    h, w = cur.shape
    n = centers.shape[0]
    half = b // 2
    top = np.rint(centers[:, 1] - half).astype(np.int64)
    left = np.rint(centers[:, 0] - half).astype(np.int64)
    pl = np.rint(predicted).astype(np.int64)
    # Top-left of the search region in prev: the block moved back by l, minus the radius.
    rt = top - pl[:, 1] - r
    rl = left - pl[:, 0] - r
    size = b + 2 * r
    ok = ((top >= 0) & (left >= 0) & (top + b <= h) & (left + b <= w)
          & (rt >= 0) & (rl >= 0) & (rt + size <= h) & (rl + size <= w))
    motion = np.zeros((n, 2))
    residual = np.full(n, np.inf)
    edge = np.ones(n, dtype=bool)
    flat = np.ones(n, dtype=bool)
    iy, ix = np.mgrid[0:b, 0:b]
    ry, rx = np.mgrid[0:size, 0:size]
    idx = np.flatnonzero(ok)
    chunk = max(1, int(2**24 // ((2 * r + 1) ** 2 * b * b)))
    for i0 in range(0, idx.size, chunk):
        sel = idx[i0:i0 + chunk]
        blocks = cur[top[sel, None, None] + iy[None], left[sel, None, None] + ix[None]]
        regions = prev[rt[sel, None, None] + ry[None], rl[sel, None, None] + rx[None]]
        win = sliding_window_view(regions, (b, b), axis=(1, 2))  # (m, 2r+1, 2r+1, b, b)
        sad = np.abs(win - blocks[:, None, None]).sum(axis=(3, 4), dtype=np.float64)
        m = sel.size
        flat_idx = sad.reshape(m, -1).argmin(axis=1)
        cy, cx = np.divmod(flat_idx, 2 * r + 1)
        s0 = sad[np.arange(m), cy, cx]
        match_tl = np.stack([rl[sel] + cx, rt[sel] + cy], axis=1)
        block_tl = np.stack([left[sel], top[sel]], axis=1)
        frac = subpixel_offsets(prev, cur, block_tl, match_tl, b)
        # Match top-left in prev = rt + cy + frac; l = block top - match top.
        my = rt[sel] + cy + frac[:, 1]
        mx = rl[sel] + cx + frac[:, 0]
        motion[sel, 0] = left[sel] - mx
        motion[sel, 1] = top[sel] - my
        residual[sel] = s0 / (b * b)
        edge[sel] = (cy == 0) | (cx == 0) | (cy == 2 * r) | (cx == 2 * r)
        flat[sel] = blocks.reshape(m, -1).std(axis=1) < config.min_std
    accepted = ok & ~edge & ~flat & (residual <= config.max_residual)
    return LocalMatches(centers, motion, residual, accepted)


def better_matches(a: LocalMatches, b: LocalMatches) -> LocalMatches:
    """Per block, the accepted match of the two searches with the lower residual.

    ``a`` and ``b`` are the same blocks searched in two windows (around the curve's
    prediction and around ``g(n)``).
    """
    take_b = b.accepted & (~a.accepted | (b.residual < a.residual))
    return LocalMatches(a.centers, np.where(take_b[:, None], b.motion, a.motion),
                        np.where(take_b, b.residual, a.residual), a.accepted | b.accepted)


def refined_velocity(local_motion: np.ndarray, dt: float, readout: float, height: int
                     ) -> np.ndarray:
    """Refined velocity from local motion, eq. 25 generalised: ``v' = l / (dt + rho l_y / h)``.

    Examples
    --------
    >>> refined_velocity(np.array([[2.2222, 11.1111]]), 1.0, 1.0, 100).round(3).tolist()
    [[2.0, 10.0]]
    """
    lm = np.asarray(local_motion, dtype=np.float64).reshape(-1, 2)
    return lm / (dt + readout * lm[:, 1:2] / height)


def row_samples(matches: LocalMatches, velocity: np.ndarray, times: np.ndarray, block: int,
                min_blocks: int, sigma: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """One velocity sample per block row: its blocks' histogram peak (Sec. V.C).

    Parameters
    ----------
    matches : LocalMatches
    velocity : ndarray of shape (N, 2)
        Refined velocity of each block (eq. 25).
    times : ndarray of shape (N,)
        Sample time of each block (midpoint of its interval).
    block : int
        Block size; blocks with the same centre row share a sample.
    min_blocks : int
        Fewest blocks at the peak a row needs; and at least half of the blocks tested in
        it.
    sigma : float
        Low-pass of the row's 2-D histogram of integer block motions, in bins.

    Returns
    -------
    times : ndarray of shape (m,)
    values : ndarray of shape (m, 2)
        Median time and velocity of the blocks within one pixel of the peak.
    """
    acc = matches.accepted
    if not acc.any():
        return np.zeros(0), np.zeros((0, 2))
    # One block row each (centres at b/2 + k b: rounding them to even would merge rows
    # imaged at different times).
    all_rows = np.floor(matches.centers[:, 1] / block).astype(np.int64)
    rows = all_rows[acc]
    v, t = velocity[acc], times[acc]
    motion = np.rint(matches.motion[acc]).astype(np.int64)
    out_t, out_v = [], []
    for row in np.unique(rows):
        sel = np.flatnonzero(rows == row)
        tested = int((all_rows == row).sum())
        if sel.size < max(min_blocks, 0.5 * tested):
            continue
        ref = np.median(motion[sel], axis=0).astype(np.int64)
        rel = motion[sel] - ref
        peak, _ = histogram_peak(rel, int(np.abs(rel).max()) + 2, sigma)
        near = sel[np.all(np.abs(rel - peak) <= 1, axis=1)]
        # A few false matches must not make a sample: at least half of the row's tested
        # blocks must agree (a row whose true motion neither window held keeps only
        # scattered false matches).
        if near.size >= max(min_blocks, 0.5 * tested):
            out_t.append(float(np.median(t[near])))
            out_v.append(np.median(v[near], axis=0))
    if not out_t:
        return np.zeros(0), np.zeros((0, 2))
    return np.asarray(out_t), np.asarray(out_v)
