"""Per-scanline velocity from sparse samples by Bezier curves (paper Sec. V.B, eq. 13-19).

Liang, Chang & Chen (2008), Sec. V.B. The global motion ``g(n)`` of a frame gives one
velocity sample per frame (eq. 13, ``v'((n + 0.5)T) = g(n) / T``); a cubic Bezier curve
(eq. 14) through the four nearest samples (eq. 15-18) gives the velocity of every
scanline (eq. 19). Unlike piecewise-linear interpolation it does not jump at frame
boundaries, which is what causes over-compensation after a sudden stop (Fig. 6-7).

Generalisation to a readout ratio ``rho`` and to real timestamps
-----------------------------------------------------------------
With time in frame intervals, scanline ``r`` of a frame starting at ``t_n`` is imaged
at ``t_n + rho r / h`` (:mod:`unjello.timing`). ``g(n)`` is the displacement of the
middle scanline of frame ``n`` from where its content was in frame ``n - 1``: the
content at row ``y`` of frame ``n`` was at row ``y - g_y`` of frame ``n - 1``, so by
eq. 1, 2 and 12 ``g(n)`` is the integral of ``v`` over
``[t_{n-1} + rho (y - g_y) / h, t_n + rho y / h]``, an interval of length
``dt + rho g_y / h`` with ``dt = t_n - t_{n-1}`` (the paper's eq. 25 for the local
motion, ``T - l_y``, is the same interval). By the mean value theorem (eq. 10)
``g(n) / (dt + rho g_y / h)`` is the velocity at some instant of that interval; eq. 13's
``g(n) / T`` is the case without vertical motion (a diagonal pan of 17 px a frame down
a 360-line frame at ``rho = 0.6`` would be 3 % off). The paper writes the sample at the
interval's *end*, ``(n + 0.5)T`` (eq. 13); we place it at the interval's *midpoint*
``tau_n = (t_{n-1} + t_n) / 2 + rho (h - 1 - g_y) / (2h)``, which is exact for a
velocity that changes linearly and removes a half-frame lag (the lag itself
over-compensates after a stop, the artefact Sec. V.B sets out to avoid). For ``rho = 1``,
a constant rate and no vertical motion ``tau_n = n``, so the four samples around frame
``n``'s scanlines ``[n, n + 1)`` are ``tau_{n-1} .. tau_{n+2}``, evenly spaced, and
eq. 15-18 hold with ``lambda = 0, 1/3, 2/3, 1``; eq. 19 becomes
``lambda = (t - tau_{n-1}) / 3``. With variable frame rate or vertical motion the
samples are not evenly spaced and the ``lambda`` of each sample is its relative
position in the span of the four, which keeps the curve through them.

Clip ends: the first frame has no previous frame and so no ``g``; where fewer than two
samples exist on one side of a scanline, the window of four slides inward (the curve is
then extrapolated), and query times outside the span of all samples are clamped to the
nearest sample (constant velocity). With fewer than four samples in total the curve
has the degree that the samples allow (a single sample gives a constant velocity).
"""

from __future__ import annotations

from math import comb

import numpy as np

__all__ = [
    "initial_velocity",
    "global_sample_time",
    "bernstein",
    "bezier_control_points",
    "bezier_eval",
    "scanline_velocity",
]


def initial_velocity(g: np.ndarray, interval: float = 1.0, readout: float = 0.0,
                     height: int = 1) -> np.ndarray:
    """Velocity sample from a global motion vector, eq. 13 with eq. 10's interval.

    ``v' = g(n) / (dt + rho g_y / h)``: the content of the middle scanline moved by
    ``g(n)`` between the instants it was imaged in the two frames, ``g_y / h`` of a
    readout apart beyond the frames' ``dt`` (see the module notes). Without vertical
    motion (or with ``readout = 0``) this is the paper's ``g(n) / T``.

    Parameters
    ----------
    g : ndarray of shape (2,)
        Global motion vector between the middle scanlines of two frames.
    interval : float
        Time between the two frames' starts, in frame intervals (1 at constant rate).
    readout : float
        Readout ratio ``rho``.
    height : int
        Frame height ``h``.

    Returns
    -------
    ndarray of shape (2,)
        Velocity in px per frame interval.

    Examples
    --------
    >>> initial_velocity(np.array([11.0, 11.0]), 1.0, 1.0, 100).round(4).tolist()
    [9.9099, 9.9099]
    """
    g = np.asarray(g, dtype=np.float64)
    return g / (float(interval) + readout * g[1] / height)


def global_sample_time(start_prev: float, start_cur: float, readout: float, height: int,
                       g_y: float = 0.0) -> float:
    """Time at which the velocity sample of ``g(n)`` is placed (eq. 13, see module notes).

    The midpoint of the interval over which the middle scanline's content moved by
    ``g(n)``: from ``t_{n-1} + rho (y_m - g_y) / h`` to ``t_n + rho y_m / h``,
    ``y_m = (h - 1) / 2``.

    Examples
    --------
    >>> global_sample_time(4.0, 5.0, 1.0, 2)
    4.75
    """
    return 0.5 * (start_prev + start_cur) + readout * (height - 1 - g_y) / (2.0 * height)


def bernstein(lam: np.ndarray, degree: int = 3) -> np.ndarray:
    """Bernstein basis of the Bezier curve, eq. 14 for ``degree = 3``.

    Parameters
    ----------
    lam : array_like of shape (...)
        Curve parameter ``0 <= lambda <= 1``.
    degree : int
        Curve degree (3 in the paper).

    Returns
    -------
    ndarray of shape (..., degree + 1)
        ``[(1-l)^3, 3 l (1-l)^2, 3 l^2 (1-l), l^3]`` for the cubic.
    """
    lam = np.asarray(lam, dtype=np.float64)[..., None]
    k = np.arange(degree + 1)
    coef = np.array([comb(degree, int(i)) for i in k], dtype=np.float64)
    return coef * lam**k * (1.0 - lam) ** (degree - k)


def bezier_control_points(lam: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Control points of the Bezier curve through samples, eq. 15-18.

    Parameters
    ----------
    lam : ndarray of shape (..., k)
        Distinct curve parameters of the ``k`` samples (``0, 1/3, 2/3, 1`` in eq. 15-18).
    values : ndarray of shape (..., k, d)
        Sample values (``d = 2`` for ``(v_x, v_y)``).

    Returns
    -------
    ndarray of shape (..., k, d)
        Control points ``c_1 .. c_k`` with ``q(lam_i) = values_i``.

    Examples
    --------
    >>> lam = np.array([0, 1/3, 2/3, 1])
    >>> c = bezier_control_points(lam, np.array([[0.], [1.], [8.], [27.]]) / 27)
    >>> np.round(c.ravel(), 6).tolist() == [0, 0, 0, 1]
    True
    """
    lam = np.asarray(lam, dtype=np.float64)
    k = lam.shape[-1]
    basis = bernstein(lam, k - 1)  # (..., k, k)
    return np.linalg.solve(basis, np.asarray(values, dtype=np.float64))


def bezier_eval(control: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """Evaluate a Bezier curve, eq. 14: ``q(l) = sum_i B_i(l) c_i``.

    Parameters
    ----------
    control : ndarray of shape (..., k, d)
        Control points.
    lam : ndarray of shape (...)
        Curve parameter per curve.

    Returns
    -------
    ndarray of shape (..., d)
    """
    basis = bernstein(lam, control.shape[-2] - 1)  # (..., k)
    return np.einsum("...k,...kd->...d", basis, control)


def scanline_velocity(
    sample_times: np.ndarray, sample_values: np.ndarray, times: np.ndarray
) -> np.ndarray:
    """Velocity at arbitrary times from the four samples around each, eq. 15-19.

    Parameters
    ----------
    sample_times : ndarray of shape (m,)
        Distinct times of the velocity samples (any order).
    sample_values : ndarray of shape (m, 2)
        Velocity samples.
    times : ndarray of shape (q,)
        Query times, e.g. the scanline times of a frame.

    Returns
    -------
    ndarray of shape (q, 2)
        ``v'(t)`` per query: the cubic Bezier through the two samples before and the two
        after ``t``, with ``lambda`` the position of ``t`` in their span (eq. 19).

    Examples
    --------
    A cubic velocity is reproduced exactly between its samples:

    >>> ts = np.array([0.0, 1.0, 2.0, 3.0])
    >>> vs = np.stack([ts**3, -ts], axis=1)
    >>> np.round(scanline_velocity(ts, vs, np.array([1.5])), 6).tolist()
    [[3.375, -1.5]]
    """
    st = np.asarray(sample_times, dtype=np.float64)
    sv = np.asarray(sample_values, dtype=np.float64).reshape(-1, 2)
    q = np.asarray(times, dtype=np.float64)
    if st.size == 0:
        return np.zeros((q.size, 2))
    order = np.argsort(st)
    st, sv = st[order], sv[order]
    m = st.size
    if m == 1:
        return np.repeat(sv, q.size, axis=0)
    k = min(4, m)
    qc = np.clip(q, st[0], st[-1])
    idx = np.searchsorted(st, qc, side="right")
    start = np.clip(idx - k // 2, 0, m - k)
    win = start[:, None] + np.arange(k)[None]
    t_win = st[win]
    span = t_win[:, -1] - t_win[:, 0]
    lam_s = (t_win - t_win[:, :1]) / span[:, None]
    ctrl = bezier_control_points(lam_s, sv[win])
    lam_q = (qc - t_win[:, 0]) / span
    return bezier_eval(ctrl, lam_q)
