"""A frame's dominant translation by phase correlation, up to the frame's own size.

:func:`cv2.phaseCorrelate` correlates cyclically: a shift ``t`` and ``t - w`` (the
frame's width) are one peak, reported between ``-w/2`` and ``w/2``, and what leaves one
side wraps in at the other. A pan of 60 % of the width a frame then read as one of -40 %
the other way (the camera followed backwards, the frame left uncorrected or made worse),
a tilt over more than half the height likewise. :func:`phase_correlate` also correlates
the copies zero-padded to twice their size (a linear correlation: shifts up to the
whole frame are told apart) and checks its strongest peaks, and the cyclic one, by how
well each lays one copy on the other where they overlap.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["phase_correlate", "PEAKS", "OVERLAP", "BETTER", "KEPT", "WHITEN"]

#: The padded correlation's strongest local peaks that are checked. (``docs/tuning.md#peaks``)
PEAKS = 8
#: A shift is checked only where the copies still overlap by this share of their width
#: and of their height.
OVERLAP = 0.25
#: The cyclic peak is kept unless another lays the copies on each other this many times
#: better (a mean absolute difference under this share of its own; ``docs/tuning.md#better``).
BETTER = 0.5
#: The share of the overlap's pixels, those that match best, whose mean absolute difference scores a
#: shift: a near object moving on its own may cover the rest. (``docs/tuning.md#kept``)
KEPT = 0.75
#: The padded correlation's spectrum is divided by its magnitude plus this share of the
#: magnitude's mean (:func:`_padded_surface`).
WHITEN = 1e-4


def phase_correlate(a: np.ndarray, b: np.ndarray, search: float = 0.0
                    ) -> list[tuple[np.ndarray, float]]:
    """Measure the translation ``t`` with ``a(s) ~ b(s + t)``, and its peak's strength.

    Both grey copies (same shape, float32) are correlated with a Hann window, cyclically
    (:func:`cv2.phaseCorrelate`) and, where that peak is ``search`` px or more from zero,
    less their means, zero-padded to twice their size. The cyclic peak and the padded
    correlation's :data:`PEAKS` strongest are each scored by the mean absolute difference
    of the copies where that shift overlaps them (at least :data:`OVERLAP` of each side),
    over the :data:`KEPT` best-matching pixels. (The cyclic reading of a shift beyond
    half the frame, its alias, is itself more than a quarter of the frame: a small
    ``search`` spares footage that moves little the padded correlation, 1 ms a pair.)

    Returns
    -------
    list of (ndarray of shape (2,), float)
        The cyclic peak's ``(dx, dy)`` (pixels of the copies) and strength (0-1: low for
        no dominant translation); then, where another scores under :data:`BETTER` times
        its score, that one, at the overlap cost's sub-pixel minimum near it: the last is
        the best. (A flow started from both keeps what each follows: from the cyclic peak
        alone where it was right, as before; a near pole's pixels followed from a pole's
        shift the overlap did not prefer.)

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> scene = cv2.GaussianBlur(rng.uniform(0, 255, (90, 400)).astype(np.float32), (0, 0), 2)
    >>> a, b = scene[:, 96:256], scene[:, :160]  # a(s) = b(s + (96, 0)): 60 % of the width
    >>> [round(float(shift[0])) for shift, _ in phase_correlate(a, b)]  # cyclic: an alias
    [-64, 96]
    """
    h, w = a.shape[:2]
    window = cv2.createHanningWindow((w, h), cv2.CV_32F)
    # Copies: cv2.phaseCorrelate applies the window to its inputs in place.
    (dx, dy), response = cv2.phaseCorrelate(a.copy(), b.copy(), window)
    found = [(np.array([dx, dy], np.float32), float(response))]
    if np.hypot(dx, dy) < search:
        return found
    own = _overlap_cost(a, b, round(dx), round(dy))
    surface = _padded_surface(a, b, window)
    best, best_cost = None, own
    for y, x in _peaks(surface, PEAKS):
        cost = _overlap_cost(a, b, x - w, y - h)
        if cost < best_cost:
            best, best_cost = (y, x), cost
    if best is None or not best_cost < BETTER * own:
        return found
    y, x = best
    # As cv2.phaseCorrelate's: the sum over 5 x 5 pixels around the peak.
    strength = float(surface[max(0, y - 2):y + 3, max(0, x - 2):x + 3].sum())
    return [*found, (np.array(_settle(a, b, x - w, y - h), np.float32), strength)]


def _settle(a: np.ndarray, b: np.ndarray, dx: int, dy: int) -> tuple[float, float]:
    """Return the overlap cost's local minimum from ``(dx, dy)``, to a sub-pixel parabola's.

    A peak of the whitened correlation may sit a pixel off the shift that lays the copies
    on each other best (a sharp edge in them: 95 px where the view moved 96).
    """
    cost = {}

    def at(x: int, y: int) -> float:
        if (x, y) not in cost:
            cost[x, y] = _overlap_cost(a, b, x, y)
        return cost[x, y]

    for _ in range(4):
        step = min(((x, y) for x in (dx - 1, dx, dx + 1) for y in (dy - 1, dy, dy + 1)),
                   key=lambda p: at(*p))
        if step == (dx, dy):
            break
        dx, dy = step

    def vertex(lo: float, mid: float, hi: float) -> float:
        curve = lo - 2.0 * mid + hi
        return 0.5 * (lo - hi) / curve if np.isfinite(curve) and curve > 0 else 0.0

    return (dx + vertex(at(dx - 1, dy), at(dx, dy), at(dx + 1, dy)),
            dy + vertex(at(dx, dy - 1), at(dx, dy), at(dx, dy + 1)))


def _padded_surface(a: np.ndarray, b: np.ndarray, window: np.ndarray) -> np.ndarray:
    """Return the phase correlation of the windowed copies zero-padded to twice their size.

    Indexed ``[dy + h, dx + w]``: the peak of a shift ``t`` (``a(s) ~ b(s + t)``).
    """
    h, w = a.shape[:2]
    shape = (2 * h, 2 * w)
    fa = np.fft.rfft2((a - float(a.mean())) * window, shape)
    fb = np.fft.rfft2((b - float(b.mean())) * window, shape)
    cross = fb * np.conj(fa)
    size = np.abs(cross)
    # Whitened, less where the windowed copies hold next to nothing (a smooth picture's
    # highest frequencies): divided by their own size there they are noise, whose peak
    # a blurred texture's 96-px shift lost to one at (1, 89).
    cross /= size + WHITEN * float(size.mean()) + 1e-12
    surface = np.fft.irfft2(cross, shape).astype(np.float32)
    return np.fft.fftshift(surface)


def _peaks(surface: np.ndarray, count: int) -> list[tuple[int, int]]:
    """Return the ``count`` strongest positive local maxima (5 x 5) inside the border."""
    top = cv2.dilate(surface, np.ones((5, 5), np.uint8))
    top[[0, -1], :] = top[:, [0, -1]] = np.inf  # no 3 x 3 neighbourhood there
    ys, xs = np.nonzero((surface >= top) & (surface > 0))
    order = np.argsort(-surface[ys, xs])[:count]
    return [(int(ys[i]), int(xs[i])) for i in order]


def _overlap_cost(a: np.ndarray, b: np.ndarray, dx: int, dy: int) -> float:
    """Mean ``|a(s) - b(s + (dx, dy))|`` where both are inside, over its :data:`KEPT` best.

    ``inf`` where they overlap too little (:data:`OVERLAP`).
    """
    h, w = a.shape[:2]
    x0, x1, y0, y1 = max(0, -dx), min(w, w - dx), max(0, -dy), min(h, h - dy)
    if x1 - x0 < OVERLAP * w or y1 - y0 < OVERLAP * h:
        return float("inf")
    diff = cv2.absdiff(a[y0:y1, x0:x1], b[y0 + dy:y1 + dy, x0 + dx:x1 + dx]).ravel()
    kept = max(1, int(KEPT * diff.size))
    return float(np.partition(diff, kept - 1)[:kept].mean())
