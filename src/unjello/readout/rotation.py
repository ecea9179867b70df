"""The readout from a camera that turns: a rotation per scanline, seen through a lens.

A hand-held camera mostly turns. Through a short focal length a turn is not a
translation of the picture: a roll moves the two halves of a row opposite ways, a pan
moves the frame's edges further than its middle, and a wide lens bends all of it. The
translation model of :mod:`unjello.readout.footage` explains that with a readout about
0.1 too long (``docs/readout.md``). Here the camera's orientation ``phi(t)`` (three
small angles, sampled every 1/32 of a frame interval) is fitted to the flow of a grid of
cells, each cell's centre ``p`` seen at ``t_a = t_k + rho y / h`` in frame ``k`` and at
``t_b = t_{k-1} + rho y' / h`` in frame ``k - 1`` (Karpenko et al. 2011; the gyro
method's model): its flow is ``D(q) J(q) (phi(t_b) - phi(t_a))``, with ``q`` the cell's
ray through the lens, ``J`` the rotational flow of a ray and ``D`` the lens's Jacobian
from rays to pixels. Under the true readout one smooth orientation explains every pair;
under a wrong one it must bend where one frame's last rows meet the next one's first.

The lens, where none is given, is the one whose fit explains the flow best (a pinhole or
OpenCV's fisheye model, its focal length and first coefficient): the flow of a turning
camera through the wrong lens contradicts itself at every readout.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_solve_banded, cholesky_banded

from ..lens import Lens

__all__ = ["CellFlows", "RotationFit", "cell_flows", "describe_lens", "fit_rotation",
           "parabola_minimum", "rotation_costs"]

#: Cells across the frame's width whose median flow is an equation pair.
CELLS = 24
#: A cell counts where at least this share of its pixels has reliable flow.
CELL_SHARE = 0.3
#: Orientation samples a frame interval.
KNOTS = 32
#: Weight of the orientation's acceleration penalty (per equation, pixels at the focal
#: length): strong enough to carry it across the blanking (``docs/readout.md``).
SMOOTHNESS = 10.0
#: Reweighting rounds against cells that do not turn with the camera (a passing car,
#: parallax), their residuals weighed down beyond this many robust deviations.
ROBUST, ROBUST_KNEE = 2, 3.0
#: Frame pairs a window of the fit holds (windows overlap by half).
WINDOW = 4
#: Focal lengths tried, as multiples of the width (fields of view of 140 to 14 degrees),
#: and the fisheye's first coefficient (0 equidistant; 1/3 near a pinhole).
FOCALS = (0.3, 0.42, 0.6, 0.85, 1.2, 1.7, 2.4, 4.0)
FISHEYE_K1 = (0.0, 0.12, 0.24)
#: Windows (spread over the clip) the lens is chosen on.
LENS_WINDOWS = 8
#: A focal length fitted to the flow is known to this ratio at best (on two real hand-held runs
#: it came 8-12 % long): the readout's change over it enters its uncertainty.
LENS_STEP = 1.1
#: Readouts (within this of the fit's) the lens's share of the uncertainty is read over.
LENS_NEAR = 0.1


@dataclass(frozen=True)
class CellFlows:
    """Median flow of a grid of cells of one frame pair, in full-frame pixels.

    Attributes
    ----------
    points : ndarray of shape (m, 2)
        Cell centres ``(x, y)`` in the later frame.
    flow : ndarray of shape (m, 2)
        Where the cell's content is in the earlier frame, minus ``points``.
    weight : ndarray of shape (m,)
        Share of the cell's pixels with reliable flow.
    """

    points: np.ndarray
    flow: np.ndarray
    weight: np.ndarray


def cell_flows(flow: np.ndarray, ok: np.ndarray, cells: int = CELLS) -> CellFlows:
    """Median reliable flow of each cell of a ``cells``-wide grid.

    Parameters
    ----------
    flow : ndarray of shape (h, w, 2)
        Flow from a frame to its previous one.
    ok : ndarray of bool, shape (h, w)
        Reliable pixels.
    cells : int
        Cells across the width (square cells).

    Examples
    --------
    >>> f = np.zeros((40, 40, 2), np.float32); f[..., 0] = 2.0
    >>> c = cell_flows(f, np.ones((40, 40), bool), cells=4)
    >>> c.points.shape, float(c.flow[0, 0]), float(c.weight.min())
    ((16, 2), 2.0, 1.0)
    """
    h, w = ok.shape
    c = max(4, w // cells)
    rows, cols = h // c, w // c
    f = flow[:rows * c, :cols * c].reshape(rows, c, cols, c, 2).swapaxes(1, 2)
    f = f.reshape(rows, cols, c * c, 2)
    good = ok[:rows * c, :cols * c].reshape(rows, c, cols, c).swapaxes(1, 2)
    good = good.reshape(rows, cols, c * c)
    share = good.mean(axis=-1)
    keep = share >= CELL_SHARE
    if not keep.any():
        empty = np.zeros((0, 2))
        return CellFlows(empty, empty, np.zeros(0))
    picked = np.where(good[keep][..., None], f[keep], np.nan)
    med = np.nanmedian(picked, axis=1)
    yy, xx = np.nonzero(keep)
    points = np.stack([(xx + 0.5) * c - 0.5, (yy + 0.5) * c - 0.5], axis=1)
    return CellFlows(points, med.astype(np.float64), share[keep].astype(np.float64))


def _ray_jacobian(q: np.ndarray) -> np.ndarray:
    """How a ray ``(u, v, 1)`` moves on the ``z = 1`` plane per small turn about x, y, z.

    Returns shape (m, 2, 3).
    """
    u, v = q[:, 0], q[:, 1]
    return np.stack([np.stack([u * v, -(1 + u * u), v], axis=-1),
                     np.stack([1 + v * v, -u * v, -u], axis=-1)], axis=1)


def _pixel_jacobian(lens: Lens, q: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """``d pixel / d ray`` at rays ``q`` (m, 2): shape (m, 2, 2), by central differences."""
    e = 1e-4
    steps = np.array([[e, 0.0], [0.0, e]])
    cols = [(lens.distort(q + s, size) - lens.distort(q - s, size)) / (2 * e) for s in steps]
    return np.stack(cols, axis=-1)


def _turn_matrices(pairs: list[CellFlows], lens: Lens, size: tuple[int, int]
                   ) -> list[np.ndarray]:
    """Each cell's flow per small turn, ``D(q) J(q)`` at its mid-point's ray: (m, 2, 3)."""
    out = []
    for c in pairs:
        q = lens.undistort(c.points + 0.5 * c.flow, size)
        out.append(np.einsum("mij,mjk->mik", _pixel_jacobian(lens, q, size),
                             _ray_jacobian(q)))
    return out


def _window_cost(t_a: np.ndarray, t_b: np.ndarray, turn: np.ndarray, flow: np.ndarray,
                 weight: np.ndarray, focal: float) -> tuple[float, float]:
    """Fit ``phi`` to one window's cells; return its robust cost (misfit + penalty).

    Also returns the cells' motion under the same (robust) weights, ``sum w |flow|^2``:
    the cost's share of it is what the rotation leaves unexplained.

    Each equation ``flow = turn (phi(t_b) - phi(t_a))`` touches four orientation samples
    (linear interpolation at both ends) of each of the three angles; the normal
    equations are assembled directly (twelve unknowns an equation).
    """
    from ..motion.dense.camera import second_difference_band

    step = 1.0 / KNOTS
    t0 = float(min(t_a.min(), t_b.min())) - step
    n = int(np.ceil((max(float(t_a.max()), float(t_b.max())) + step - t0) / step)) + 2
    ua, ub = (t_a - t0) / step, (t_b - t0) / step
    ia, ib = np.floor(ua).astype(int), np.floor(ub).astype(int)
    fa, fb = ua - ia, ub - ib
    knots = np.stack([ib, ib + 1, ia, ia + 1], axis=1)            # (m, 4)
    interp = np.stack([1 - fb, fb, -(1 - fa), -fa], axis=1)       # (m, 4)
    m, size = t_a.size, 3 * n
    # Unknowns knot-major (sample k's three angles at 3k .. 3k + 2): the normal matrix is
    # a band as wide as the time an equation spans (about a frame interval).
    cols = (knots[:, :, None] * 3 + np.arange(3)[None, None, :]).reshape(m, 12)
    cols = np.concatenate([cols, cols])
    vals = np.concatenate([(interp[:, :, None] * turn[:, a, None, :]).reshape(m, 12)
                           for a in range(2)])
    rhs = np.concatenate([flow[:, 0], flow[:, 1]])
    base = np.concatenate([weight, weight])
    bw = int((cols.max(axis=1) - cols.min(axis=1)).max()) if m else 6
    bw = max(bw, 6)
    pi, qi = np.triu_indices(12)
    ci, cj = cols[:, pi], cols[:, qi]
    lo, hi = np.minimum(ci, cj), np.maximum(ci, cj)
    slot = ((bw + lo - hi) * size + hi).ravel()
    # The acceleration penalty, per angle: second differences of samples three apart.
    pen = np.zeros((bw + 1, size))
    scale = SMOOTHNESS * weight.sum() * step * focal ** 2
    second = second_difference_band(n)  # row 2 - lag: the knots' lag-th superdiagonal
    for lag in range(3):
        for ch in range(3):
            pen[bw - 3 * lag, 3 * np.arange(n) + ch] += scale * second[2 - lag]
    w = base
    for it in range(ROBUST + 1):
        band = np.bincount(slot, (w[:, None] * vals[:, pi] * vals[:, qi]).ravel(),
                           minlength=(bw + 1) * size).reshape(bw + 1, size) + pen
        band[bw] += 1e-9 * band[bw].mean() + 1e-12
        atb = np.bincount(cols.ravel(), (vals * (w * rhs)[:, None]).ravel(), minlength=size)
        x = cho_solve_banded((cholesky_banded(band), False), atb)
        resid = np.sum(vals * x[cols], axis=1) - rhs
        if it < ROBUST:
            spread = max(1.4826 * float(np.median(np.abs(resid))), 0.05)
            w = base / (1.0 + (resid / (ROBUST_KNEE * spread)) ** 2)
    acc = np.diff(x.reshape(n, 3), 2, axis=0)
    penalty = scale * float(np.sum(acc ** 2))
    motion = float(np.sum(w * rhs ** 2))
    return float(np.sum(w * resid ** 2)) + penalty, motion


def rotation_costs(pairs: list[CellFlows], times: np.ndarray, lens: Lens,
                   size: tuple[int, int], readouts: np.ndarray, every: int = 1
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Return the fit's cost of each readout and the motion it fits, window by window.

    Both have shape (windows, readouts) (see :func:`_window_cost`).

    Parameters
    ----------
    pairs : list of CellFlows
        Cell flows of consecutive frame pairs (pair ``k`` from frame ``k + 1`` to ``k``).
    times : ndarray
        Start time of each frame, in frame intervals.
    lens : Lens
        The lens the rays are seen through.
    size : (int, int)
        Frame height and width.
    readouts : ndarray
        Candidate readouts, fractions of the frame interval.
    every : int
        Fit every ``every``-th window only.
    """
    from ..motion.dense.camera import BLAS

    h = size[0]
    turn = _turn_matrices(pairs, lens, size)
    starts = list(range(0, max(1, len(pairs) - WINDOW // 2), WINDOW // 2))[::every]
    out = np.zeros((len(starts), readouts.size))
    motion = np.zeros_like(out)
    for j, k0 in enumerate(starts):
        ks = [k for k in range(k0, min(k0 + WINDOW, len(pairs))) if pairs[k].weight.size]
        if not ks:
            continue
        y = np.concatenate([pairs[k].points[:, 1] for k in ks])
        dy = np.concatenate([pairs[k].flow[:, 1] for k in ks])
        ta0 = np.concatenate([np.full(pairs[k].weight.size, times[k + 1]) for k in ks])
        tb0 = np.concatenate([np.full(pairs[k].weight.size, times[k]) for k in ks])
        tn = np.concatenate([turn[k] for k in ks])
        flow = np.concatenate([pairs[k].flow for k in ks])
        wgt = np.concatenate([pairs[k].weight for k in ks])
        with BLAS.limit(limits=1, user_api="blas"):
            for i, rho in enumerate(readouts):
                out[j, i], motion[j, i] = _window_cost(ta0 + rho * y / h,
                                                       tb0 + rho * (y + dy) / h, tn, flow,
                                                       wgt, lens.focal)
    return out, motion


@dataclass(frozen=True)
class RotationFit:
    """The rotation model's readout and lens.

    Attributes
    ----------
    readout : float
        The cost's minimum (interpolated between candidates).
    uncertainty : float
        One standard deviation, from the spread of the minimum when each window is left
        out in turn (jackknife) and, for a fitted lens, its focal length's
        (:attr:`lens_share`); ``inf`` where the minimum is at the candidates' edge.
    lens : Lens
        The lens fitted (or given).
    candidates, costs : ndarray
        Readout candidates and the total cost of each.
    lens_costs : dict
        Each lens tried (:func:`describe_lens`) and its cost at its best coarse readout.
    turning : bool
        Whether the lens explains the flow better than the longest focal length tried
        (:data:`FOCALS`), a turn that is all but a translation: where it does not, the
        scene's motion is a translation's and :mod:`~unjello.readout.footage`'s model
        stands.
    explained : float
        Share of the cells' motion (weighted as the robust fit weighs them) that the
        rotation explains at the readout found.
    spread : float
        Standard deviation of the windows' own minima.
    lens_share : float
        The fitted lens's share of ``uncertainty`` (:func:`_lens_sigma`; 0 for a lens
        given).
    """

    readout: float
    uncertainty: float
    lens: Lens
    candidates: np.ndarray
    costs: np.ndarray
    lens_costs: dict
    turning: bool
    explained: float
    spread: float
    lens_share: float = 0.0


def parabola_minimum(candidates: np.ndarray, costs: np.ndarray) -> float:
    """Return the parabola's minimum through the lowest cost and its neighbours."""
    b = int(np.argmin(costs))
    if 0 < b < costs.size - 1:
        lo, mid, hi = costs[b - 1:b + 2]
        den = lo - 2 * mid + hi
        if den > 0:
            step = candidates[b + 1] - candidates[b]
            return float(candidates[b] + step * 0.5 * (lo - hi) / den)
    return float(candidates[b])


def describe_lens(lens: Lens) -> str:
    """Name a lens in words: ``pinhole f 835`` or ``fisheye f 243 k1 -0.015`` (pixels)."""
    if lens.k is None:
        return f"pinhole f {lens.focal:.0f}"
    return f"fisheye f {lens.focal:.0f} k1 {lens.k[0]:.3f}"


def fit_rotation(pairs: list[CellFlows], times: np.ndarray, size: tuple[int, int],
                 lens: Lens | None = None, candidates: np.ndarray | None = None
                 ) -> RotationFit:
    """Fit the rotation model: the lens (unless given), then the readout.

    The lenses (:data:`FOCALS` as pinholes and as fisheyes of each :data:`FISHEYE_K1`)
    are scored at three readouts on :data:`LENS_WINDOWS` windows; the best one's focal
    length and coefficient are refined between their neighbours; the readout is then the
    minimum of the total cost over ``candidates`` (default 0.1 to 1.2 by 0.05: a minimum
    at 1.0 lies inside them), and its uncertainty the jackknife's over the windows with,
    for a fitted lens, its focal length's share (:func:`_lens_sigma`).
    """
    h, w = size
    if candidates is None:
        candidates = np.round(np.arange(0.1, 1.2001, 0.05), 4)
    lens_costs: dict[str, float] = {}
    coarse = np.array([0.3, 0.6, 0.9])
    windows = max(1, (len(pairs) - WINDOW // 2) // (WINDOW // 2))
    every = max(1, int(np.ceil(windows / LENS_WINDOWS)))

    def score(trial: Lens) -> float:
        c = rotation_costs(pairs, times, trial, size, coarse, every=every)[0].sum(axis=0)
        lens_costs[describe_lens(trial)] = float(c.min())
        return float(c.min())
    far = Lens(FOCALS[-1] * w)
    fitted = lens is None
    if lens is not None:
        turning = score(lens) < score(far)
    else:
        trials = ([Lens(s * w) for s in FOCALS]
                  + [Lens(s * w, (k, 0.0, 0.0, 0.0)) for s in FOCALS[:5] for k in FISHEYE_K1])
        scores = [score(t) for t in trials]
        best = trials[int(np.argmin(scores))]
        # Refine: the focal length between the grid's neighbours (log-spaced), and a
        # fisheye's first coefficient between its neighbours, in halving steps.
        ratio, dk = float(np.sqrt(FOCALS[1] / FOCALS[0])), 0.5 * (FISHEYE_K1[1] - FISHEYE_K1[0])
        for _ in range(3):
            moves = [Lens(best.focal * ratio, best.k), Lens(best.focal / ratio, best.k)]
            if best.k is not None:
                moves += [Lens(best.focal, (best.k[0] + sign * dk, 0.0, 0.0, 0.0))
                          for sign in (1, -1)]
            for trial in moves:
                if score(trial) < lens_costs[describe_lens(best)]:
                    best = trial
            ratio, dk = float(np.sqrt(ratio)), 0.5 * dk
        lens, turning = best, best.focal < far.focal
    per_window, motion = rotation_costs(pairs, times, lens, size, candidates)
    costs = per_window.sum(axis=0)
    rho = parabola_minimum(candidates, costs)
    b = int(np.argmin(costs))
    explained = float(1.0 - costs[b] / max(float(motion[:, b].sum()), 1e-12))
    spread = float(np.std([parabola_minimum(candidates, row) for row in per_window]))
    share = 0.0
    if b in (0, candidates.size - 1) or len(per_window) < 3:
        sigma = float("inf")
    else:
        loo = np.array([parabola_minimum(candidates, costs - row) for row in per_window])
        k = len(loo)
        sigma = float(np.sqrt((k - 1) / k * np.sum((loo - loo.mean()) ** 2)))
        if fitted and turning:
            share = _lens_sigma(pairs, times, size, lens, candidates, rho)
            sigma = float(np.hypot(sigma, share))
    return RotationFit(rho, sigma, lens, candidates, costs, lens_costs, turning, explained,
                       spread, share)


def _lens_sigma(pairs: list[CellFlows], times: np.ndarray, size: tuple[int, int],
                lens: Lens, candidates: np.ndarray, rho: float) -> float:
    """Return the readout's uncertainty from the fitted lens's.

    Half the readout's change between the focal lengths ``f / LENS_STEP`` and
    ``f LENS_STEP``: a focal length fitted to the flow is known no better. On TUM RS-VI
    sequences 4 and 9 the fit's came 8-12 % longer than a bundle adjustment's, the
    translation of a hand-held camera, seen near and far, looking like a flatter lens,
    however well the windows agreed on it (``docs/readout.md``). Read over the readouts
    within :data:`LENS_NEAR` of the fit's ``rho`` (a fifth of the cost of all of them).
    """
    near = np.abs(candidates - rho) <= LENS_NEAR + 1e-9
    near[np.argsort(np.abs(candidates - rho))[:3]] = True
    sub = candidates[near]
    moved = [parabola_minimum(sub, rotation_costs(pairs, times, Lens(lens.focal * s, lens.k),
                                                  size, sub)[0].sum(axis=0))
             for s in (1.0 / LENS_STEP, LENS_STEP)]
    return float(0.5 * abs(moved[1] - moved[0]))
