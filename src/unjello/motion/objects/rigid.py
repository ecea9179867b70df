"""An object's rigid motion, imaged one scanline at a time, scored against its neighbours.

What :mod:`unjello.motion.objects.spinners` fits to an object the flow failed on -- a rotation, or a
velocity of its own (:func:`fit_drift`: a near pole passing in front faster than the
scene behind it) -- is scored here: each candidate predicts where every pixel of the
object appears in a neighbouring frame, solved per pixel for the scanline that images it
there (the paper's eq. 10 timing), and the truncated grey-level difference with what
that frame shows there is its cost (:func:`costs`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np

from ..._kernels.drift import drift_costs
from ..._kernels.field import grid_plus

__all__ = ["Spin", "Track", "PathTrack", "carried", "carried_out", "costs", "drift_scorer",
           "fit_drift", "prepare", "rotate", "TRUNCATE", "MOVING", "DRIFT_PENALTY"]

#: Grey-level difference at which the match cost saturates (an occluded or
#: mis-modelled pixel costs no more than this).
TRUNCATE = 40.0
#: A pixel the surroundings' motion leaves at least this far from its neighbours (grey
#: levels) belongs to the object; only such pixels score a rotation.
MOVING = 10.0
#: A drift's cost is raised by this share of itself at the search's reach, in proportion
#: to its speed (:func:`fit_drift`): among drifts that match alike, the slowest.
DRIFT_PENALTY = 0.15
#: The drifts searched on the shrunk copy are at most this many a side (then further apart than its
#: pixels, on a copy blurred to match. (``docs/tuning.md#grid_side``)
GRID_SIDE = 41

Track = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class Spin:
    """A rigid rotation fitted to a region of one frame.

    Attributes
    ----------
    centre : ndarray of shape (2,)
        Centre ``C(t_ref)`` (x, y) in the frame's pixels at its reference time.
    omega : float
        Angular velocity, radians per frame interval (positive: clockwise on screen,
        from +x towards +y).
    cost : float
        Mean truncated absolute difference of the region's pixels and where the rotation
        puts them in the neighbouring frames (grey levels).
    still_cost : float
        The same with no rotation: the region moving with its surroundings. Both are
        measured on the pixels that the surroundings' motion does not explain.
    drift : ndarray of shape (2,)
        The object's own velocity (px per frame interval) on top of its surroundings':
        non-zero for an object moving on its own (:func:`fit_drift`; a near pole passing
        in front, ``omega`` 0), zero for a rotation.
    """

    centre: np.ndarray
    omega: float
    cost: float
    still_cost: float
    drift: np.ndarray = field(default_factory=lambda: np.zeros(2))

    @property
    def gain(self) -> float:
        """How much better the rotation explains the region than no rotation (ratio)."""
        return self.still_cost / max(self.cost, 1e-6)


def rotate(v: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Rotate vectors ``v`` (..., 2) by angles ``a`` (radians, from +x towards +y)."""
    c, s = np.cos(a), np.sin(a)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)


class PathTrack:
    """A track from a path sampled at ``times`` (linear between, held at the ends).

    ``track(t) = (c(t) + t u) * scale + t drift``, per axis, with ``c(t)`` rounded to
    float32 as the dense method's camera path is. The rigid fits evaluate their track
    thousands of times a frame (:func:`predict`'s fixed point, for every candidate):
    :meth:`complex` gives it as ``x + iy`` with one interpolation, where a general track
    takes two and a stack (a 320x180 pole clip's correction 0.29 -> 0.22 CPU s a frame, the
    same output; ``docs/history/measurements.md``).
    """

    def __init__(self, times: np.ndarray, path: np.ndarray,
                 u: np.ndarray | tuple[float, float] = (0.0, 0.0)) -> None:
        self.times = np.asarray(times, np.float64)
        self.path = np.asarray(path)[:, 0] + 1j * np.asarray(path)[:, 1]
        self.u = complex(float(u[0]), float(u[1]))
        self.scale = (1.0, 1.0)
        self.drift = 0j

    def complex(self, t: np.ndarray) -> np.ndarray:
        """Return the track at times ``t`` (any shape) as complex positions, complex128."""
        t = np.asarray(t, np.float64)
        z = np.interp(t, self.times, self.path).astype(np.complex64) + t * self.u
        if self.scale != (1.0, 1.0):
            z = z.real * self.scale[0] + 1j * (z.imag * self.scale[1])
        return z + t * self.drift if self.drift else z

    def __call__(self, t: np.ndarray) -> np.ndarray:
        """Return the track at times ``t``: shape ``t.shape + (2,)``."""
        z = self.complex(t)
        return np.stack([z.real, z.imag], axis=-1)

    def carried(self, drift: np.ndarray | tuple[float, float]) -> PathTrack:
        """Return this track with a velocity ``drift`` (x, y per frame interval) added."""
        out = PathTrack.__new__(PathTrack)
        out.times, out.path, out.u, out.scale = self.times, self.path, self.u, self.scale
        v = complex(float(drift[0]), float(drift[1]))
        if not self.u and not self.drift and self.scale == (1.0, 1.0):
            out.u, out.drift = v, 0j  # added where a lambda would: the path's own velocity
        else:
            out.drift = self.drift + v
        return out

    def scaled(self, scale: np.ndarray | tuple[float, float]) -> PathTrack:
        """Return this track in pixels ``scale`` (x, y) times as large."""
        out = self.carried((0.0, 0.0))
        out.scale = (self.scale[0] * float(scale[0]), self.scale[1] * float(scale[1]))
        out.drift = self.drift.real * float(scale[0]) + 1j * self.drift.imag * float(scale[1])
        return out


def carried(track: Track, drift: np.ndarray) -> Track:
    """Return ``track`` with a constant velocity ``drift`` (px per frame interval) added."""
    if not np.any(drift):
        return track
    if isinstance(track, PathTrack):
        return track.carried(drift)
    v = np.asarray(drift, np.float64)
    return lambda t: np.asarray(track(t), np.float64) + np.asarray(t, np.float64)[..., None] * v


def carried_out(shape: tuple[int, int], offset: float, track: Track, readout: float
                ) -> np.ndarray:
    """Pixels that the camera's motion (``track``) carries outside the frame ``offset`` away.

    Each row is moved by the track's change from its own time to the same row's time in
    that frame (``readout`` of a frame interval from the first row to the last). Bool.
    """
    h, w = shape
    t_rows = readout * np.arange(h) / h
    d = (at(track, t_rows + offset) - at(track, t_rows)).astype(np.float32)
    return ~grid_plus(np.ascontiguousarray(np.broadcast_to(d[:, None], (h, w, 2))))[2]


def at(track: Track, t: np.ndarray) -> np.ndarray:
    """``track`` at times of any shape: shape ``t.shape + (2,)``."""
    t = np.asarray(t, np.float64)
    return np.asarray(track(t.ravel()), np.float64).reshape(t.shape + (2,))


def _complex_at(track: Track, t: np.ndarray) -> np.ndarray:
    """``track`` at times of any shape, as complex positions ``x + iy``."""
    if isinstance(track, PathTrack):
        return track.complex(t)
    p = at(track, t)
    return p[..., 0] + 1j * p[..., 1]


#: Fixed-point iterations that find where a rigid motion, imaged row by row, puts a pixel.
PREDICT_ITERATIONS = 5


def predict(pts: np.ndarray, t_s: np.ndarray, centre: np.ndarray, omega: np.ndarray,
             track: Track, t_ref: float, offset: float, row_time: float,
             iterations: int = PREDICT_ITERATIONS, drift: np.ndarray | None = None) -> np.ndarray:
    """Where points ``pts`` (n, 2), imaged at ``t_s``, appear in a frame starting at ``offset``.

    For every rotation of ``omega`` (m,) about ``centre`` (m, 2), carried by ``track``
    plus its own ``drift`` (m, 2; none: zero), at once: shape (m, n, 2).
    The point's scanline in that frame fixes the time it is imaged there, which fixes
    where it is: solved by iterating ``t' = offset + row_time * y'`` (converges while the
    object's rim moves less than a row per row of readout). Without rotation a point
    moves by the track's and its drift's change, ``q = s + C(t') - C(t_s) + v (t' - t_s)``,
    so its scanline depends on the drift's vertical part alone: the times are solved once
    per distinct vertical drift.
    """
    z = pts[:, 0] + 1j * pts[:, 1]
    dz = (np.zeros(len(centre)) if drift is None else drift[:, 0] + 1j * drift[:, 1])[:, None]
    start = offset + row_time * pts[None, :, 1]
    if not np.any(omega):  # drifts alone
        vy, which = np.unique(dz.imag, return_inverse=True)
        vy = vy[:, None]
        ty_s = _complex_at(track, t_s).imag
        t_o = np.repeat(start, len(vy), axis=0)
        for _ in range(iterations - 1):
            t_o = offset + row_time * (pts[None, :, 1] + _complex_at(track, t_o).imag - ty_s
                                       + vy * (t_o - t_s[None]))
        t_o = t_o[which.ravel()]
        q = z[None] + _complex_at(track, t_o) - _complex_at(track, t_s)[None] + dz * (
            t_o - t_s[None])
        return np.stack([q.real, q.imag], axis=-1)
    cz = centre[:, 0] + 1j * centre[:, 1]
    c_ref = _complex_at(track, np.array(t_ref)) + dz * t_ref
    rel = z[None] - (cz[:, None] + _complex_at(track, t_s)[None] + dz * t_s[None] - c_ref)
    t_o = np.broadcast_to(start, rel.shape)
    for _ in range(iterations):
        q = cz[:, None] + _complex_at(track, t_o) + dz * t_o - c_ref + rel * np.exp(
            1j * omega[:, None] * (t_o - t_s[None]))
        t_o = offset + row_time * q.imag
    return np.stack([q.real, q.imag], axis=-1)


def sample(image: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Sample ``image`` bilinearly at points of any shape.

    The maps are folded into rows of 1024, under OpenCV's 32767-column limit.
    """
    n = x.size
    cols = 1024
    pad = -n % cols
    mx = np.concatenate([x.ravel(), np.zeros(pad)]).astype(np.float32).reshape(-1, cols)
    my = np.concatenate([y.ravel(), np.zeros(pad)]).astype(np.float32).reshape(-1, cols)
    out = cv2.remap(image, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    return out.ravel()[:n].reshape(x.shape)


def costs(image: np.ndarray, others: Sequence[tuple[np.ndarray, float]], pts: np.ndarray,
           centre: np.ndarray, omega: np.ndarray, track: Track, t_ref: float,
           row_time: float, iterations: int = PREDICT_ITERATIONS, drift: np.ndarray | None = None
           ) -> np.ndarray:
    """Return each point's truncated difference with its predictions, shape (m, n).

    Averaged over the neighbours in which the point is predicted inside the frame.
    """
    h, w = image.shape
    if not np.any(omega):
        scorer = drift_scorer(image, others, pts, track, row_time, iterations)
        if scorer is not None:  # drifts alone: compiled (its reference: the NumPy below)
            return scorer(np.zeros((len(omega), 2)) if drift is None else drift)
    t_s = row_time * pts[:, 1]
    own = sample(image, pts[:, 0], pts[:, 1])
    total = np.zeros((len(omega), len(pts)))
    seen = np.zeros_like(total)
    for other, offset in others:
        q = predict(pts, t_s, centre, omega, track, t_ref, offset, row_time, iterations,
                     drift)
        val = sample(other, q[..., 0], q[..., 1])
        inside = ((q[..., 0] >= 0) & (q[..., 0] <= w - 1) & (q[..., 1] >= 0)
                  & (q[..., 1] <= h - 1))
        total += np.where(inside, np.minimum(np.abs(val - own[None]), TRUNCATE), 0.0)
        seen += inside
    return np.where(seen > 0, total / np.maximum(seen, 1), TRUNCATE)


def drift_scorer(image: np.ndarray, others: Sequence[tuple[np.ndarray, float]],
                 pts: np.ndarray, track: Track, row_time: float, iterations: int
                 ) -> Callable[[np.ndarray], np.ndarray] | None:
    """:func:`costs` of drifts alone (no rotation) on these points, made ready once.

    Compiled (:func:`~unjello._kernels.drift.drift_costs`) for a :class:`PathTrack` and one
    or two neighbours; None otherwise.
    """
    if not isinstance(track, PathTrack) or not 1 <= len(others) <= 2:
        return None
    return drift_costs(sample(image, pts[:, 0], pts[:, 1]), list(others), pts, track.times,
                       track.path, track.u, track.scale, track.drift, row_time, iterations,
                       TRUNCATE)


def pattern_search(cost: Callable[[np.ndarray], np.ndarray], x: np.ndarray, best: float,
                   steps: np.ndarray, scales: Sequence[float],
                   allowed: Callable[[np.ndarray], np.ndarray] | None = None
                   ) -> tuple[float, np.ndarray]:
    """Minimise ``cost`` from ``x`` (cost ``best``) by steps of shrinking size.

    At each size in ``scales``, every step of ``steps`` (k, d) in turn, times the size, is
    tried from where the search stands and taken where it lowers the cost; the turns
    repeat until none does. The steps of a turn left to try are scored together
    (``cost`` takes points (m, d) and returns m costs): the points scored and the path
    are those of trying them one at a time, in a fraction of the calls. Points where
    ``allowed`` is False are not tried.
    """
    for size in scales:
        moved = True
        while moved:
            moved, turn = False, 0
            while turn < len(steps):
                probes = x + steps[turn:] * size
                ok = np.ones(len(probes), bool) if allowed is None else allowed(probes)
                c = np.full(len(probes), np.inf)
                if ok.any():
                    c[ok] = cost(probes[ok])
                better = np.flatnonzero(c < best)
                if not better.size:
                    break
                k = int(better[0])
                best, x, moved, turn = float(c[k]), probes[k], True, turn + k + 1
    return best, x


@dataclass(frozen=True)
class Prepared:
    """A region made ready to score motions on: its points, and a shrunk copy."""

    centroid: np.ndarray  # at the reference time
    radius: float
    scale: np.ndarray  # the shrunk copy's size over the frame's (x, y)
    small: np.ndarray  # the frame, shrunk
    sothers: list[tuple[np.ndarray, float]]  # the neighbours, shrunk
    strack: Track  # the surroundings' motion in the shrunk copy's pixels
    spts: np.ndarray  # up to 300 moving points of the shrunk copy
    fine: np.ndarray  # up to 1500 moving points at full size


def prepare(image: np.ndarray, others: Sequence[tuple[np.ndarray, float]],
             region: np.ndarray, track: Track, t_ref: float, readout: float,
             coarse_radius: float) -> Prepared | None:
    """Shrink the frame until ``region``'s radius is about ``coarse_radius``; pick points.

    Only the points the surroundings' motion does not explain (:data:`MOVING`) score a
    motion: the object, not the background seen through it. None when the region is too
    small (under 200 px, a radius under 8 px; under 30 px in the shrunk copy), nothing
    moves against the surroundings, or there is no neighbour.
    """
    h, w = image.shape
    ys, xs = np.nonzero(region)
    if len(xs) < 200 or not others:
        return None
    pts = np.stack([xs, ys], axis=1).astype(np.float64)
    centroid = pts.mean(axis=0)
    radius = float(np.percentile(np.linalg.norm(pts - centroid, axis=1), 95))
    if radius < 8:
        return None
    # The centroid is where the object was at its mean scanline's time; at t_ref:
    centroid = (centroid - at(track, np.array(readout / h * centroid[1]))
                + at(track, np.array(t_ref)))

    def moving(img: np.ndarray, oth: list, p: np.ndarray, trk: Track, rt: float
               ) -> np.ndarray:
        still = costs(img, oth, p, np.zeros((1, 2)), np.zeros(1), trk, t_ref, rt)[0]
        return p[still >= MOVING]

    f = max(1.0, radius / coarse_radius)
    size = (max(8, round(w / f)), max(8, round(h / f)))
    small = [cv2.resize(im, size, interpolation=cv2.INTER_AREA) for im in (image, *[
        o for o, _ in others])]
    sreg = cv2.resize(region.astype(np.uint8), size, interpolation=cv2.INTER_NEAREST)
    sy, sx = np.nonzero(sreg)
    if len(sx) < 30:
        return None  # it all but vanished in the shrunk copy (a line a pixel wide)
    scale = np.array([size[0] / w, size[1] / h])
    strack: Track = (track.scaled(scale) if isinstance(track, PathTrack)
                     else lambda t: np.asarray(track(t)) * scale)
    sothers = [(o, off) for o, (_, off) in zip(small[1:], others, strict=True)]
    spts = moving(small[0], sothers, np.stack([sx, sy], axis=1).astype(np.float64),
                  strack, readout / size[1])
    fine = moving(image, list(others), pts[::max(1, len(pts) // 6000)], track, readout / h)
    if len(spts) < 30 or len(fine) < 100:
        return None
    return Prepared(centroid, radius, scale, small[0], sothers, strack,
                     spts[::max(1, len(spts) // 300)], fine[::max(1, len(fine) // 1500)])


#: The pattern search's steps, in the order they are tried.
STEPS = np.array([(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)])


#: An object's radius (px) on the shrunk copy its rigid motions are first scored on.
COARSE_RADIUS = 16.0


#: A drift is refined only where it explains the object this many times better than none.
REFINE_GAIN = 1.15


def fit_drift(image: np.ndarray, others: Sequence[tuple[np.ndarray, float]],
              region: np.ndarray, track: Track, t_ref: float, readout: float, *,
              max_drift: float | None = None, coarse_radius: float = COARSE_RADIUS,
              min_gain: float = REFINE_GAIN, along: np.ndarray | None = None) -> Spin | None:
    """Fit ``region`` a velocity of its own on top of its surroundings': a near object.

    A pole passing close in front of the camera moves faster than the scene behind it
    (parallax) and, flat and thin, can move too far between frames for the flow to follow
    it; it is then no spinner, but a rigid object translating -- imaged one scanline at a
    time like the camera's motion, carried by ``track`` plus a constant ``drift``. Every
    drift up to ``max_drift`` (px per frame interval, either way on both axes; None: a
    sixth of the width) is scored on the shrunk copy (:func:`prepare`), as
    :func:`~unjello.motion.objects.spinners.fit_spin` scores rotations -- at most
    :data:`GRID_SIDE` a
    side, further apart than its pixels on a copy blurred to match; the best two are
    refined at full size by a shrinking pattern search.

    With ``along`` (a direction), only drifts along it are scored: seen from one side, a
    flat object's motion across that of its surroundings is unsure (the aperture: a pole
    matches itself anywhere along its length), and only a drift along it is taken.

    Returns
    -------
    Spin or None
        ``omega`` 0 and the fitted :attr:`Spin.drift`; None as :func:`prepare`, or when
        no drift on the shrunk copy explains the region ``min_gain`` times better than
        none (it is not refined then: a spinner is no drift).
    """
    prep = prepare(image, others, region, track, t_ref, readout, coarse_radius)
    if prep is None:
        return None
    h, w = image.shape
    reach = (w / 6 if max_drift is None else max_drift) * prep.scale
    # At most GRID_SIDE drifts a side; a coarser step searches a copy blurred to match.
    step = float(max(1, np.ceil(2 * reach.max() / GRID_SIDE)))
    small, others_s = prep.small, prep.sothers
    if step > 1:
        def blur(im: np.ndarray) -> np.ndarray:
            return cv2.GaussianBlur(im, (0, 0), step / 2)

        small, others_s = blur(small), [(blur(o), off) for o, off in others_s]
    if along is None:
        gx, gy = np.meshgrid(np.arange(-np.ceil(reach[0] / step), np.ceil(reach[0] / step) + 1),
                             np.arange(-np.ceil(reach[1] / step), np.ceil(reach[1] / step) + 1))
        gx, gy = gx * step, gy * step
        steps = STEPS
    else:  # the line through no drift along ``along``, at the grid's step
        u = np.asarray(along, np.float64) / float(np.hypot(*along))
        us = u * prep.scale / float(np.hypot(*(u * prep.scale)))  # in the shrunk copy
        n = np.ceil(float(np.hypot(*reach)) / step)
        k = np.arange(-n, n + 1) * step
        gx, gy = k * us[0], k * us[1]  # no drift among them: k = 0
        steps = np.stack([u, -u])
    grid = np.stack([gx.ravel(), gy.ravel()], axis=1)
    centre = np.repeat((prep.centroid * prep.scale)[None], len(grid), 0)
    spts = prep.spts[::max(1, len(prep.spts) // 120)]
    # A flat object moving along itself looks the same (the aperture problem): of drifts
    # that match alike, the slowest wins (DRIFT_PENALTY of the cost at the reach).
    raw = costs(small, others_s, spts, centre, np.zeros(len(grid)), prep.strack,
                t_ref, readout / prep.small.shape[0], iterations=2, drift=grid).mean(axis=1)
    if raw.min() * min_gain > raw[np.flatnonzero((gx == 0) & (gy == 0))[0]]:
        return None  # no drift explains it much better than its surroundings' motion
    far = float(np.hypot(*reach))
    scores = raw * (1 + DRIFT_PENALTY * np.hypot(gx, gy).ravel() / far)

    fine = prep.fine[::max(1, len(prep.fine) // 500)]

    scorer = drift_scorer(image, others, fine, track, readout / h, 3)

    def cost(vs: np.ndarray, penalty: float = DRIFT_PENALTY) -> np.ndarray:
        """Score drifts ``vs`` (m, 2) together: their costs, each raised by its speed."""
        raw = (scorer(vs) if scorer is not None else costs(
            image, others, fine, np.repeat(prep.centroid[None], len(vs), 0),
            np.zeros(len(vs)), track, t_ref, readout / h, iterations=3, drift=vs)
               ).mean(axis=1)
        return raw * (1 + penalty * np.hypot(*(vs * prep.scale).T) / far)

    results = []
    for i in np.argsort(scores)[:2]:
        v = grid[i] / prep.scale
        move = step / 2 / float(prep.scale.min())  # half the grid's step, full-size px
        sizes = []
        while move >= 0.25:
            sizes.append(move)
            move /= 2
        results.append(pattern_search(cost, v, float(cost(v[None])[0]), steps, sizes))
    v = min(results, key=lambda r: r[0])[1]
    final = cost(np.stack([v, np.zeros(2)]), 0.0)
    return Spin(centre=prep.centroid, omega=0.0, cost=float(final[0]),
                still_cost=float(final[1]), drift=v)
