"""Global motion estimation by block matching and a 2-D histogram peak (paper Sec. V.A).

Liang, Chang & Chen (2008), Sec. V.A: the current frame is cut into 16x16 blocks; for
each block the displacement with the minimal sum of absolute differences (SAD) in the
previous frame within a search range (the paper: +/-160 px) is its motion vector; the
2-D histogram of all block vectors is low-pass filtered and its peak is the global
motion vector ``g(n)`` of the frame.

The search is *exhaustive* in result but not in work: the successive elimination
algorithm (Li & Salari, IEEE TIP 1995) discards a candidate as soon as a lower bound on
its SAD already exceeds an SAD that has been reached, using the triangle inequality
``SAD >= |sum(block) - sum(candidate)|`` on the whole block and then on its 4x4
sub-blocks (all candidate sums come from one integral image). Only the survivors get an
exact SAD, so the returned vectors are those of a brute-force search, including its
tie rule (the first minimum in raster order of the candidate's position in the previous
frame), while no Python loop runs over candidate positions.

Sign: a block vector is the block's position in frame ``n`` minus its match's position
in frame ``n - 1`` (see :mod:`unjello.timing`).
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import cv2
import numpy as np

from ...errors import SettingsError
from ..flow.phase import phase_correlate

__all__ = ["BlockMatchConfig", "BlockVectors", "GlobalMotion", "block_match", "histogram_peak",
           "global_motion", "subpixel_offsets"]


@dataclass(frozen=True)
class BlockMatchConfig:
    """Settings of the global block matching (Sec. V.A and VI).

    Parameters
    ----------
    block : int
        Block size in pixels (the paper: 16).
    search : int
        Search range in pixels, in both directions (the paper: 160).
    min_std : float
        Blocks whose grey-level standard deviation (0-255 scale) is below this carry no
        motion information and are left out.
    sigma : float
        Standard deviation, in bins, of the Gaussian low-pass on the 2-D histogram.
    """

    block: int = 16
    search: int = 160
    min_std: float = 2.0
    sigma: float = 1.0

    def __post_init__(self) -> None:
        if not 1 <= self.search <= 1000:
            raise SettingsError(f"search range must be 1 to 1000 px, got {self.search}")
        if self.block < 4:
            raise SettingsError(f"block size must be at least 4 px, got {self.block}")


@dataclass(frozen=True)
class BlockVectors:
    """Result of block matching.

    Attributes
    ----------
    centers : ndarray of shape (N, 2)
        ``(x, y)`` centre of each block in the current frame.
    vectors : ndarray of shape (N, 2)
        Integer ``(dx, dy)`` of the best SAD match.
    subpixel : ndarray of shape (N, 2)
        Vectors refined to sub-pixel precision (:func:`subpixel_offsets`).
    sad : ndarray of shape (N,)
        Mean absolute difference per pixel at the best match.
    """

    centers: np.ndarray
    vectors: np.ndarray
    subpixel: np.ndarray
    sad: np.ndarray


@dataclass(frozen=True)
class GlobalMotion:
    """The global motion vector ``g(n)`` of one frame (eq. 12).

    Attributes
    ----------
    vector : ndarray of shape (2,)
        Sub-pixel ``(gx, gy)``: median of the sub-pixel vectors of the blocks within one
        pixel of the histogram peak (a median, not the mean: one block matched to a
        neighbouring bin's texture cannot pull it).
    peak : ndarray of shape (2,)
        Integer histogram peak.
    support : float
        Fraction of matched blocks within one pixel of the peak (a confidence).
    ok : bool
        False when no block could be matched (textureless or tiny frames).
    """

    vector: np.ndarray
    peak: np.ndarray
    support: float
    ok: bool

    def __bool__(self) -> bool:
        return self.ok


def _as_gray255(image: np.ndarray) -> np.ndarray:
    img = np.asarray(image)
    if img.ndim == 3:
        img = cv2.cvtColor(img[..., :3].astype(np.float32), cv2.COLOR_RGB2GRAY)
    return img.astype(np.float32, copy=False)


def _box_sums(image: np.ndarray, size: int) -> np.ndarray:
    """Sum of every ``size x size`` window, indexed by its top-left corner."""
    ii = cv2.integral(image, sdepth=cv2.CV_64F)
    return (ii[size:, size:] - ii[:-size, size:] - ii[size:, :-size] + ii[:-size, :-size])


def block_match(
    prev: np.ndarray,
    cur: np.ndarray,
    config: BlockMatchConfig = BlockMatchConfig(),
    *,
    hint: tuple[float, float] = (0.0, 0.0),
) -> BlockVectors:
    """Match every block of ``cur`` in ``prev`` by exhaustive minimal SAD.

    Parameters
    ----------
    prev, cur : ndarray of shape (H, W) or (H, W, 3)
        Previous and current frame, grey or RGB, on a 0-255 scale.
    config : BlockMatchConfig
        Block size, search range and texture threshold.
    hint : tuple of float
        A likely ``(dx, dy)`` (e.g. the previous frame's ``g``): its SAD seeds the
        elimination bound. It changes the speed, never the result.

    Returns
    -------
    BlockVectors
        One row per textured block.

    Notes
    -----
    Equivalent to evaluating ``SAD(d) = sum |cur_block - prev[block - d]|`` for every
    ``d`` in ``[-search, search]^2`` whose candidate lies inside ``prev``, and keeping the
    first minimum in raster order of the candidate position.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> a = rng.integers(0, 255, (64, 64)).astype(np.float32)
    >>> b = np.roll(a, (2, -3), axis=(0, 1))
    >>> bv = block_match(a, b, BlockMatchConfig(search=8))
    >>> np.median(bv.vectors, axis=0).tolist()
    [-3.0, 2.0]
    """
    p = _as_gray255(prev)
    c = _as_gray255(cur)
    h, w = c.shape
    b = config.block
    r = config.search
    if h < b or w < b:
        empty = np.zeros((0, 2))
        return BlockVectors(empty, empty, empty, np.zeros(0))
    s_full = _box_sums(p, b)  # (h-b+1, w-b+1)
    sub = 4 if b % 4 == 0 and b >= 8 else 1
    s_sub = _box_sums(p, sub)
    offs = np.arange(0, b, sub)
    gy, gx = np.meshgrid(offs, offs, indexing="ij")
    oy, ox = gy.ravel(), gx.ravel()
    s_half = _box_sums(p, b // 2)
    hy2, hx2 = (a.ravel() for a in np.meshgrid([0, b // 2], [0, b // 2], indexing="ij"))
    yy, xx = np.mgrid[0:b, 0:b]
    yy, xx = yy.ravel(), xx.ravel()

    def match_block(by: int, bx: int) -> tuple | None:
        blk = c[by:by + b, bx:bx + b]
        if blk.std() < config.min_std:
            return None
        y0, y1 = max(0, by - r), min(h - b, by + r)
        x0, x1 = max(0, bx - r), min(w - b, bx + r)
        ww = x1 - x0 + 1
        lb = np.abs(s_full[y0:y1 + 1, x0:x1 + 1] - float(blk.sum(dtype=np.float64))).ravel()
        flat_blk = blk.ravel()

        def sad_at(idx: np.ndarray, flat_blk=flat_blk, y0=y0, x0=x0, ww=ww) -> np.ndarray:
            cy = idx // ww + y0
            cx = idx % ww + x0
            patches = p[cy[:, None] + yy[None], cx[:, None] + xx[None]]
            return np.abs(patches - flat_blk[None]).sum(axis=1, dtype=np.float64)

        # An upper bound from a few promising candidates.
        k = min(16, lb.size)
        seeds = np.argpartition(lb, k - 1)[:k]
        hy, hx = int(round(by - hint[1])), int(round(bx - hint[0]))
        ey = np.clip(np.array([by] + [hy + d for d in (-2, -1, 0, 1, 2) for _ in range(5)]),
                     y0, y1)
        ex = np.clip(np.array([bx] + [hx + d for _ in range(5) for d in (-2, -1, 0, 1, 2)]),
                     x0, x1)
        seeds = np.concatenate([seeds, (ey - y0) * ww + (ex - x0)])
        # Bounds and SADs are float sums: a small tolerance keeps ties in.
        best = sad_at(seeds).min() * (1 + 1e-9) + 1e-3
        # Successive elimination: whole-block bound, then 4x4 sub-block bound; the
        # survivors get exact SADs in order of their bound, the bound tightening as
        # better matches are found.
        cand = np.flatnonzero(lb <= best)
        bound = lb[cand]
        if sub > 1 and cand.size > 64:
            cy = cand // ww + y0
            cx = cand % ww + x0
            h2 = b // 2
            c8 = blk.reshape(2, h2, 2, h2).sum(axis=(1, 3)).ravel()
            bound = np.abs(s_half[cy[:, None] + hy2[None], cx[:, None] + hx2[None]]
                           - c8[None]).sum(axis=1)
            keep = bound <= best
            cand, bound, cy, cx = cand[keep], bound[keep], cy[keep], cx[keep]
            if cand.size > 64:
                cb = blk.reshape(b // sub, sub, b // sub, sub).sum(axis=(1, 3)).ravel()
                bound = np.abs(s_sub[cy[:, None] + oy[None], cx[:, None] + ox[None]]
                               - cb[None]).sum(axis=1)
                keep = bound <= best
                cand, bound = cand[keep], bound[keep]
        if cand.size == 0:  # rounding removed even the seeds: search them exactly
            cand = np.unique(seeds)
            bound = np.zeros(cand.size)
        order = np.argsort(bound, kind="stable")
        cand, bound = cand[order], bound[order]
        done_idx, done_sad = [], []
        pos = 0
        while pos < cand.size:
            chunk = cand[pos:pos + 256]
            sad_c = sad_at(chunk)
            done_idx.append(chunk)
            done_sad.append(sad_c)
            best = min(best, float(sad_c.min()) * (1 + 1e-9) + 1e-3)
            pos += chunk.size
            rest = bound[pos:] <= best
            cand = np.concatenate([cand[:pos], cand[pos:][rest]])
            bound = np.concatenate([bound[:pos], bound[pos:][rest]])
        idx_all = np.concatenate(done_idx)
        sad = np.concatenate(done_sad)
        s_min = sad.min()
        ties = idx_all[sad == s_min]
        i_best = int(ties.min())
        s0 = float(s_min)
        py, px = i_best // ww + y0, i_best % ww + x0
        return (bx + b / 2, by + b / 2), (bx - px, by - py), s0 / (b * b)

    # Blocks are independent and NumPy releases the GIL in its loops: two threads.
    positions = [(by, bx) for by in range(0, h - b + 1, b) for bx in range(0, w - b + 1, b)]
    with ThreadPoolExecutor(max_workers=min(2, os.cpu_count() or 1)) as pool:
        found = [m for m in pool.map(lambda yx: match_block(*yx), positions) if m is not None]
    centers = [m[0] for m in found]
    vecs = [m[1] for m in found]
    sads = [m[2] for m in found]
    centers_a = np.asarray(centers, dtype=np.float64).reshape(-1, 2)
    vecs_a = np.asarray(vecs, dtype=np.float64).reshape(-1, 2)
    tl = (centers_a - b / 2).astype(np.int64)
    delta = subpixel_offsets(p, c, tl, tl - vecs_a.astype(np.int64), b)
    return BlockVectors(centers=centers_a, vectors=vecs_a, subpixel=vecs_a - delta,
                        sad=np.asarray(sads, dtype=np.float64))


def subpixel_offsets(prev: np.ndarray, cur: np.ndarray, block_tl: np.ndarray,
                     match_tl: np.ndarray, block: int) -> np.ndarray:
    """Sub-pixel offset of integer block matches by one Lucas-Kanade step.

    Solves ``cur_block(x) = prev(x + m + delta)`` for ``delta`` in the least-squares
    sense after linearising ``prev`` at the integer match ``m`` (Lucas & Kanade 1981):
    ``delta = (G^T G)^-1 G^T (cur_block - prev_patch)`` with ``G`` the gradient of
    ``prev`` on the patch. Exact whole-pixel matches give ``delta = 0``.

    Parameters
    ----------
    prev, cur : ndarray of shape (H, W), float32
        Previous and current frame.
    block_tl : ndarray of shape (N, 2)
        Integer ``(x, y)`` top-left of each block in ``cur``.
    match_tl : ndarray of shape (N, 2)
        Integer ``(x, y)`` top-left of its match in ``prev``.
    block : int
        Block size.

    Returns
    -------
    ndarray of shape (N, 2)
        ``(dx, dy)`` offsets of the match positions, clipped to +/-1 px.
    """
    n = block_tl.shape[0]
    if n == 0:
        return np.zeros((0, 2))
    gy, gx = np.gradient(prev)
    iy, ix = np.mgrid[0:block, 0:block]
    cy = block_tl[:, 1, None, None] + iy
    cx = block_tl[:, 0, None, None] + ix
    my = match_tl[:, 1, None, None] + iy
    mx = match_tl[:, 0, None, None] + ix
    r = (cur[cy, cx] - prev[my, mx]).reshape(n, -1).astype(np.float64)
    jx = gx[my, mx].reshape(n, -1).astype(np.float64)
    jy = gy[my, mx].reshape(n, -1).astype(np.float64)
    a11, a12, a22 = (jx * jx).sum(1), (jx * jy).sum(1), (jy * jy).sum(1)
    b1, b2 = (jx * r).sum(1), (jy * r).sum(1)
    det = a11 * a22 - a12 * a12
    ok = det > 1e-6 * (a11 + a22) ** 2 + 1e-12
    safe = np.where(ok, det, 1.0)
    dx = np.where(ok, (a22 * b1 - a12 * b2) / safe, 0.0)
    dy = np.where(ok, (a11 * b2 - a12 * b1) / safe, 0.0)
    return np.clip(np.stack([dx, dy], axis=1), -1.0, 1.0)


def histogram_peak(
    vectors: np.ndarray, search: int, sigma: float = 1.0
) -> tuple[np.ndarray, np.ndarray]:
    """Return the peak of the low-pass filtered 2-D histogram of block vectors.

    Parameters
    ----------
    vectors : ndarray of shape (N, 2)
        Integer block vectors ``(dx, dy)`` within ``[-search, search]``.
    search : int
        Search range; the histogram has ``(2 * search + 1)^2`` bins.
    sigma : float
        Gaussian low-pass standard deviation in bins (0 disables it).

    Returns
    -------
    peak : ndarray of shape (2,)
        The ``(dx, dy)`` of the highest filtered bin.
    histogram : ndarray of shape (2 * search + 1, 2 * search + 1)
        The filtered histogram, indexed ``[dy + search, dx + search]``.

    Examples
    --------
    >>> v = np.array([[3, -1]] * 7 + [[10, 4], [-5, 0], [0, 0]])
    >>> histogram_peak(v, 16)[0].tolist()
    [3, -1]
    """
    n = 2 * search + 1
    v = np.asarray(vectors, dtype=np.int64).reshape(-1, 2) + search
    counts = np.zeros((n, n), dtype=np.float32)
    np.add.at(counts, (v[:, 1], v[:, 0]), 1.0)
    hist: np.ndarray = counts
    if sigma > 0:
        hist = cv2.GaussianBlur(counts, (0, 0), sigma, borderType=cv2.BORDER_CONSTANT)
    iy, ix = np.unravel_index(int(np.argmax(hist)), hist.shape)
    return np.array([ix - search, iy - search], dtype=np.int64), hist


def _phase_hint(prev: np.ndarray, cur: np.ndarray) -> tuple[float, float]:
    """Whole-frame translation by phase correlation: a seed for the exact search."""
    (dx, dy), _ = phase_correlate(_as_gray255(prev), _as_gray255(cur))[-1]
    return float(dx), float(dy)


def global_motion(
    prev: np.ndarray,
    cur: np.ndarray,
    config: BlockMatchConfig = BlockMatchConfig(),
    *,
    hint: tuple[float, float] | None = None,
) -> GlobalMotion:
    """Estimate the global motion vector ``g(n)`` of ``cur`` relative to ``prev`` (Sec. V.A).

    Parameters
    ----------
    prev, cur : ndarray of shape (H, W) or (H, W, 3)
        Consecutive frames on a 0-255 scale.
    config : BlockMatchConfig
        Block matching settings.
    hint : tuple of float, optional
        Likely vector, to speed up the search (see :func:`block_match`); default: the
        whole-frame translation by phase correlation. It never changes the result.

    Returns
    -------
    GlobalMotion
        Falsy (``ok=False``) when no block could be matched.
    """
    if hint is None:
        hint = _phase_hint(prev, cur)
    bv = block_match(prev, cur, config, hint=hint)
    if len(bv.vectors) == 0:
        return GlobalMotion(np.zeros(2), np.zeros(2, dtype=np.int64), 0.0, False)
    peak, _ = histogram_peak(bv.vectors, config.search, config.sigma)
    near = np.all(np.abs(bv.vectors - peak) <= 1, axis=1)
    vec = np.median(bv.subpixel[near], axis=0) if near.any() else peak.astype(np.float64)
    return GlobalMotion(vec, peak, float(near.mean()), True)
