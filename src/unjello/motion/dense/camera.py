"""The camera's image-plane trajectory at scanline resolution, from row-flow equations.

Row ``y`` of frame ``k`` is imaged at ``t = t_k + rho y / h`` (the paper's eq. 10 with
readout ``rho``); its content was at row ``y + f_y`` of frame ``k - 1``, imaged at
``t' = t_{k-1} + rho (y + f_y) / h``. The robust flow of each row gives one equation
``c(t) - c(t') = -f`` on the trajectory ``c``, sampled on a fine time grid.
:func:`solve_camera_trajectory` solves all of a window's equations together by
regularised least squares (a penalty on the second difference of ``c``), with a row
velocity for what varies along the frame but not over time, and optional sinusoids
for vibration (:mod:`unjello.motion.dense.vibration`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import linalg
from threadpoolctl import ThreadpoolController

__all__ = ["BLAS", "ROBUST_KNEE", "KNOT_SEEN", "KNOT_TIE", "OUTLIER_SPREAD",
           "OUTLIER_FLOOR", "CameraSolution", "solve_camera_trajectory", "solve_reweighted",
           "second_difference_band"]

# The camera solves are small (a few hundred unknowns): one BLAS thread is faster, and
# BLAS threads spinning beside the encoder's cost ten times more (measured: 25 vs 3 ms).
BLAS = ThreadpoolController()

#: Acceleration beyond this many times the median is penalised by its size rather than its
#: square when ``robust`` rounds are asked for (``benchmarks/readout.py``, docs/tuning.md).
ROBUST_KNEE = 3.0

#: An equation whose misfit is this many times the median misfit weighs half as much in
#: :func:`solve_reweighted` (a Cauchy weight; three times as far off, a tenth), ...
OUTLIER_SPREAD = 3.0
#: ... the median taken as this many pixels at least (a clean pan leaves misfits of
#: hundredths: then nothing is an outlier).
OUTLIER_FLOOR = 0.5

#: A row-velocity knot reached with under this share of the median knot's weight is partly
#: unseen: tied to its neighbours by up to KNOT_TIE (``docs/tuning.md#knot_seen``).
KNOT_SEEN, KNOT_TIE = 0.1, 0.1

def _interp_matrix(times: np.ndarray, t0: float, step: float, n: int) -> tuple[np.ndarray,
                                                                                  np.ndarray,
                                                                                  np.ndarray]:
    """Return indices and weights of linear interpolation of grid values at ``times``."""
    u = np.clip((times - t0) / step, 0, n - 1 - 1e-9)
    i0 = np.floor(u).astype(np.int64)
    f = u - i0
    return i0, 1.0 - f, f


def second_difference_band(n: int, weights: np.ndarray | None = None) -> np.ndarray:
    """``D2^T W D2`` for the second-difference operator on ``n`` samples, as a 3-row upper band.

    Row ``2 - d`` holds the ``d``-th superdiagonal (LAPACK's upper band storage, right
    aligned). Without ``weights`` (one per second difference, ``n - 2``), ``W = I``: the
    diagonal is ``1, 5, 6, ..., 6, 5, 1``, the first superdiagonal ``-2, -4, ..., -4, -2``,
    the second all ones.
    """
    band = np.zeros((3, n))
    if n >= 3:
        w = np.ones(n - 2) if weights is None else weights
        band[2] = np.convolve(w, [1.0, 4.0, 1.0])
        band[1, 1:] = np.convolve(w, [-2.0, -2.0])
        band[0, 2:] = w
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


def _knot_penalty(reach: np.ndarray) -> np.ndarray:
    """Penalty on the row velocity's knots, given how much data reaches each (k, k).

    Roughness (second differences, 1e-3) and a ridge (1e-4) on every knot the equations
    reach with at least :data:`KNOT_SEEN` of the median knot's weight; below that the
    ridge fades and a tie to the neighbouring knots (:data:`KNOT_TIE`) takes over, so
    that rows no equation reaches keep the velocity of the rows beside them. Where every
    knot is reached, the ridge and roughness alone, as before.

    Examples
    --------
    >>> p = _knot_penalty(np.array([0.0, 0.0, 5.0, 5.0, 5.0]))
    >>> bool(p[0, 0] > 0.05 and abs(p[0, 1]) > 0.05), round(float(p[4, 4]), 4)
    (True, 0.0011)
    """
    k = reach.size
    seen = np.ones(k)
    if (reach > 0).any():
        seen = np.clip(reach / (KNOT_SEEN * float(np.median(reach[reach > 0]))), 0.0, 1.0)
    d1 = np.diff(np.eye(k), axis=0)
    tie = 1.0 - np.minimum(seen[1:], seen[:-1])
    return (1e-3 * _band_to_dense(second_difference_band(k)) + 1e-4 * np.diag(seen)
            + KNOT_TIE * d1.T @ (tie[:, None] * d1))


#: Knots of the row velocity ``u`` over the frame height (linear in between).
ROW_KNOTS = 16


def solve_camera_trajectory(t_a: np.ndarray, t_b: np.ndarray, rows: np.ndarray | None,
                            delta: np.ndarray, weight: np.ndarray, step: float,
                            smoothness: float, row_knots: int = ROW_KNOTS,
                            freqs: np.ndarray | None = None, robust: int = 0
                            ) -> CameraSolution:
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
    robust : int
        Reweighting rounds (iteratively reweighted least squares) that make the penalty
        on an acceleration beyond :data:`ROBUST_KNEE` times the median grow with its
        size rather than its square: a velocity that changes within a fraction of a
        frame (a pan starting from still) then costs its size, not its size squared
        over its duration, which favoured a readout that spread it out.

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
    if freqs.size or not ku:
        b_cu = c_rows(border)
    else:  # each equation touches two of u's knots: scatter those alone (8 products, not 4k)
        knot = np.stack([ir, ir + 1], axis=1)[:, None, :]
        near = np.take_along_axis(border, knot[:, 0], axis=1)[:, None, :]
        b_cu = np.bincount((cols[:, :, None] * k + knot).ravel(),
                           (vals[:, :, None] * near).ravel(), minlength=n * k).reshape(n, k)
    c_uu = border.T @ border
    scale = weight.sum()
    # Acceleration of c: sum (d2 c / step^2)^2 * step ~ integral of the squared acceleration.
    data_band = band.copy()
    band[bw - 2:] += smoothness * scale / step**3 * second_difference_band(n)
    if ku:
        # u: small roughness and ridge penalties (a constant velocity belongs to c). A
        # knot that few equations reach (rows with no reliable flow: the rows entering at
        # the top of a fast vertical pan, flat sky) is tied to its neighbours instead of
        # pulled to zero, which stopped those rows' camera (:func:`_knot_penalty`).
        c_uu[:ku, :ku] += scale * _knot_penalty(np.diag(c_uu)[:ku])
    jitter = 1e-9 * ((band[bw].sum() + np.trace(c_uu)) / (n + k) + 1e-12)
    band[bw] += jitter
    c_uu += jitter * np.eye(k)
    with BLAS.limit(limits=1, user_api="blas"):
        sol = _solve_bordered_banded(band, b_cu, c_uu, atb)
        for _ in range(robust):
            accel = np.linalg.norm(np.diff(sol[:n], 2, axis=0), axis=1)
            knee = max(ROBUST_KNEE * float(np.median(accel)), 1e-3 * float(accel.max()), 1e-12)
            band = data_band.copy()
            relief = np.minimum(1.0, knee / (accel + 1e-12))
            band[bw - 2:] += smoothness * scale / step**3 * second_difference_band(n, relief)
            band[bw] += jitter
            sol = _solve_bordered_banded(band, b_cu, c_uu, atb)
    cost = float((rhs ** 2).sum() - (sol * atb).sum())
    c, u = sol[:n], sol[n:n + ku]
    if freqs.size:
        ph = 2 * np.pi * (step * np.arange(n))[:, None] * freqs
        c = c + np.concatenate([np.cos(ph), np.sin(ph)], axis=1) @ sol[n + ku:]
    return CameraSolution(t0, step, c - c.mean(axis=0), u, cost)


def solve_reweighted(t_a: np.ndarray, t_b: np.ndarray, rows: np.ndarray,
                     delta: np.ndarray, weight: np.ndarray, step: float, smoothness: float
                     ) -> CameraSolution:
    """:func:`solve_camera_trajectory`, then again with the rows it leaves unexplained weighed down.

    A frame pair's rows can follow something other than the scene: over flat sky, a near
    pole that the flow followed across a row is all that row's pixels agree on (a pan of
    40 % of the width a frame read 166 px a frame on a third of a pair's rows, the pole's
    speed, where the scene moved 128). The other pairs and the smoothness of the path
    disagree with them, and least squares splits the difference. After a first solve
    each equation's weight is divided by ``1 + (r / (OUTLIER_SPREAD * m))^2``, where ``r``
    is its misfit and ``m`` the median misfit (at least :data:`OUTLIER_FLOOR` px), and the
    trajectory is solved again: rows three times as far off as the median count half,
    nine times as far a tenth. Where no row is three times as far off, the first solve
    stands (a clean path: no second solve to pay).

    Examples
    --------
    A pan of 40 px a frame over five pairs (readout 0.7), a third of one pair's rows
    reading 52 (a near object's speed): the path's worst error on the rows, a third.

    >>> ta = np.concatenate([k + np.linspace(0, 0.69, 30) for k in range(1, 6)])
    >>> tb, y = ta - 1.0, np.tile(np.linspace(0, 1, 30), 5)
    >>> delta = np.tile([40.0, 0.0], (150, 1)); delta[60:70, 0] = 52.0
    >>> plain = solve_camera_trajectory(ta, tb, y, delta, np.ones(150), 1 / 256, 0.003)
    >>> again = solve_reweighted(ta, tb, y, delta, np.ones(150), 1 / 256, 0.003)
    >>> def worst(sol): return float(np.abs(sol.differences(ta, tb, y)[:, 0] - 40.0).max())
    >>> worst(plain) > 5.0, worst(again) < worst(plain) / 3
    (True, True)
    """
    sol = solve_camera_trajectory(t_a, t_b, rows, delta, weight, step, smoothness)
    misfit = np.hypot(*(delta - sol.differences(t_a, t_b, rows)).T)
    spread = OUTLIER_SPREAD * max(float(np.median(misfit)), OUTLIER_FLOOR)
    if float(misfit.max()) <= spread:
        return sol  # every row within three times the median: none to outvote
    return solve_camera_trajectory(t_a, t_b, rows, delta,
                                   weight / (1.0 + (misfit / spread) ** 2), step, smoothness)

