"""The field helpers' compiled passes against the NumPy steps they replace, bit for bit."""

import threading
import time

import cv2
import numpy as np
import pytest

from unjello._kernels.field import (
    fill_from_weights,
    fixed_point_maps,
    grid_plus,
    lands_inside,
    projective_maps,
)
from unjello.motion.dense.field import (
    PRIOR_BELOW,
    fill_unreliable,
    fit_projective,
    projective_flow,
    snap_to_global,
)
from unjello.motion.flow.patches import patch_cost
from unjello.timing import pixel_grid


def _field(h=27, w=48, seed=0):
    rng = np.random.default_rng(seed)
    return rng.normal(0, 3, (h, w, 2)).astype(np.float32)


def _fill_reference(resid, ok, num, w, prior):
    """The NumPy tail of ``fill_unreliable`` as it was."""
    avg = num / np.stack([np.maximum(w, 1e-3)] * 2, axis=-1)
    if prior is None:
        avg[w <= 1e-3] = 0.0
    elif float(w.min()) <= PRIOR_BELOW:
        np.copyto(avg, np.broadcast_to(prior, avg.shape), where=(w <= PRIOR_BELOW)[..., None])
    np.copyto(avg, resid, where=ok[..., None])
    return avg


@pytest.mark.parametrize("prior", ["none", "row", "pixel"])
def test_fill_from_weights_is_the_numpy_fill(prior):
    rng = np.random.default_rng(1)
    resid, num = _field(seed=2), _field(seed=3)
    ok = rng.random((27, 48)) < 0.5
    w = rng.random((27, 48)).astype(np.float32) ** 3  # many under both thresholds
    w[0, :5] = 0.0
    p = {"none": None, "row": _field(27, 1, 4), "pixel": _field(seed=5)}[prior]
    got = fill_from_weights(resid, ok, num, w, p, PRIOR_BELOW)
    want = _fill_reference(resid, ok, num, w, p)
    np.testing.assert_array_equal(got, want)
    assert got.dtype == np.float32


def test_fill_unreliable_keeps_reliable_pixels_and_takes_the_row_prior_far_from_them():
    resid = _field(60, 80)
    ok = np.zeros((60, 80), bool)
    ok[:, :20] = True
    prior = np.full((60, 1, 2), 7.0, np.float32)
    out = fill_unreliable(resid, ok, 4.0, prior=prior)
    np.testing.assert_array_equal(out[:, :20], resid[:, :20])
    assert np.all(out[:, 60:] == 7.0)  # beyond 3 sigma of any reliable pixel
    # A prior given for every pixel is the same as one given per row, broadcast.
    np.testing.assert_array_equal(
        fill_unreliable(resid, ok, 4.0, prior=np.broadcast_to(prior, resid.shape)), out)


def test_projective_maps_are_the_projective_flow_and_its_maps():
    h, w = 27, 48
    flow = _field(h, w)
    coef = np.array([1.5, -0.3, 0.2, -2.0, 0.1, 0.4, 0.05, -0.07])
    glob, (gmx, gmy), (fmx, fmy) = projective_maps(coef, flow)
    gx, gy = pixel_grid(h, w)
    want = projective_flow(coef, gx, gy, (h, w))
    np.testing.assert_array_equal(glob, want)
    np.testing.assert_array_equal(gmx, gx + want[..., 0])
    np.testing.assert_array_equal(gmy, gy + want[..., 1])
    np.testing.assert_array_equal(fmx, gx + flow[..., 0])
    np.testing.assert_array_equal(fmy, gy + flow[..., 1])


def test_snap_to_global_is_the_patch_comparison():
    """The compiled maps and pick give what comparing the two patch costs gave."""
    rng = np.random.default_rng(9)
    h, w = 54, 96
    other = cv2.GaussianBlur(rng.uniform(0, 255, (h, w)).astype(np.float32), (0, 0), 1.5)
    flow = np.zeros((h, w, 2), np.float32)
    flow[..., 0] = 2.0
    flow[20:30, 40:60] = (-3.0, 1.0)  # an object of its own
    gx, gy = pixel_grid(h, w)
    cur = cv2.remap(other, gx + flow[..., 0], gy + flow[..., 1], cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_REPLICATE)
    flow += rng.normal(0, 0.3, flow.shape).astype(np.float32)  # measured, noisy
    ok = np.ones((h, w), bool)
    ok[20:30, 40:60] = False  # the fit's samples: the background
    out = snap_to_global(cur, other, flow.copy(), ok, 9)
    glob = projective_flow(fit_projective(flow, ok, gx, gy), gx, gy, (h, w))
    better = patch_cost(cur, other, gx, gy, glob, 9) <= patch_cost(cur, other, gx, gy, flow, 9)
    want = np.where(better[..., None], glob, flow)
    np.testing.assert_array_equal(out, want)
    assert np.abs(out[25, 50] - (-3.0, 1.0)).max() < 1.0  # the object keeps its motion
    background = out[5:15, 5:90].reshape(-1, 2)
    assert np.abs(background - (2.0, 0.0)).max(axis=1).mean() < 0.1  # the noise gone


def test_grid_plus_is_the_grid_added():
    flow = _field(27, 48) * 10
    flow[2, 3, 0] = np.nan
    mx, my, inside = grid_plus(flow)
    gx, gy = pixel_grid(27, 48)
    np.testing.assert_array_equal(mx, gx + flow[..., 0])
    np.testing.assert_array_equal(my, gy + flow[..., 1])
    np.testing.assert_array_equal(inside, (mx >= 0) & (mx <= 47) & (my >= 0) & (my <= 26))
    assert inside.any() and not inside.all() and not inside[2, 3]
    np.testing.assert_array_equal(lands_inside(flow), inside)
    mx, my, _ = grid_plus(flow[5:9, 10:20], 5, 10)
    np.testing.assert_array_equal(mx, gx[5:9, 10:20] + flow[5:9, 10:20, 0])
    np.testing.assert_array_equal(my, gy[5:9, 10:20] + flow[5:9, 10:20, 1])


def test_kernels_let_other_threads_run():
    """A kernel releases the GIL: the flows' threads and the warp's run side by side.

    The main thread notes the time of each turn of a loop while another thread is in one
    long kernel call; holding the GIL, the kernel would stall it for the whole call (the
    kernel's own 30-110 ms, measured; released: at most 1.4 ms).
    """
    field = np.zeros((3000, 3000, 2), np.float32)
    grid_plus(field[:2, :2])  # loaded (or compiled) before the race
    span: list[float] = []

    def work():
        t = time.perf_counter()
        grid_plus(field)
        span.extend([t, time.perf_counter()])

    worker = threading.Thread(target=work)
    turns = []
    worker.start()
    while worker.is_alive():
        turns.append(time.perf_counter())
    start, end = span
    inside = [start, *(t for t in turns if start < t < end), end]
    assert max(np.diff(inside)) < 0.5 * (end - start)


def _fixed_point_reference(f, rounds):
    """``s = p + f(s)`` iterated ``rounds`` times in float64 (bilinear, position clamped)."""
    h, w = f.shape[:2]
    gx, gy = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
    f64 = f.astype(np.float64)
    sx, sy = gx + f64[..., 0], gy + f64[..., 1]
    for _ in range(rounds):
        cx, cy = np.clip(sx, 0, w - 1), np.clip(sy, 0, h - 1)
        x0, y0 = np.floor(cx).astype(int), np.floor(cy).astype(int)
        x1, y1 = np.minimum(x0 + 1, w - 1), np.minimum(y0 + 1, h - 1)
        ax, ay = (cx - x0)[..., None], (cy - y0)[..., None]
        v = ((f64[y0, x0] * (1 - ax) + f64[y0, x1] * ax) * (1 - ay)
             + (f64[y1, x0] * (1 - ax) + f64[y1, x1] * ax) * ay)
        sx, sy = gx + v[..., 0], gy + v[..., 1]
    return sx, sy


def test_fixed_point_maps_reach_the_fixed_point():
    h, w = 54, 96
    f = cv2.GaussianBlur(_field(h, w, 9), (0, 0), 6.0) * 5  # gradient 0.33: it converges
    f[..., 0] += 4.0
    ex, ey = _fixed_point_reference(f, 60)
    fine = fixed_point_maps(f, 40, 1e-5)
    assert np.abs(fine[0] - ex).max() < 1e-3 and np.abs(fine[1] - ey).max() < 1e-3
    mx, my = fixed_point_maps(f, 6, 0.01)  # stopped at a step under 0.01 px
    assert np.abs(mx - ex).max() < 0.01 and np.abs(my - ey).max() < 0.01
    # A step at most: each pixel's first iterate, the reference's first round.
    one = fixed_point_maps(f, 1, 0.0)
    rx, ry = _fixed_point_reference(f, 1)
    assert np.abs(one[0] - rx).max() < 1e-3 and np.abs(one[1] - ry).max() < 1e-3
    # OpenCV's sampling (1/32 px positions) iterated to the same tolerance: within it.
    gx, gy = pixel_grid(h, w)
    sx, sy = gx + f[..., 0], gy + f[..., 1]
    for _ in range(6):
        fs = cv2.remap(f, sx, sy, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        sx, sy = gx + fs[..., 0], gy + fs[..., 1]
    assert np.abs(mx - sx).max() < 0.02 and np.abs(my - sy).max() < 0.02
