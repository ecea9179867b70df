"""What a frame did not see beyond its edge, taken from its neighbours."""

import numpy as np
import pytest

from unjello.warp.bands import PlaneMaps
from unjello.warp.fill.neighbours import (
    beyond_rows,
    edge_slopes,
    fill_from_neighbours,
    neighbour_sources,
    unseen_share,
)
from unjello.warp.maps import remap_maps, resize_maps


def test_fill_from_neighbours_takes_what_the_frame_missed():
    # The frame sees columns 10-59 of a scene, its neighbour columns 0-49: the flow from
    # the frame to the neighbour is +10 px. Output pixels whose source is left of the
    # frame must come from the neighbour, exactly.
    rng = np.random.default_rng(1)
    scene = rng.uniform(0, 255, (40, 70)).astype(np.float32)
    frame, neighbour = scene[:, 10:60].copy(), scene[:, 0:50].copy()
    h, w = frame.shape
    mx = np.tile(np.arange(w, dtype=np.float32) - 5, (h, 1))
    my = np.tile(np.arange(h, dtype=np.float32)[:, None], (1, w))
    out = np.zeros_like(frame)
    flow = np.zeros((h // 2, w // 2, 2), np.float32)
    flow[..., 0] = 5.0  # half-resolution grid: 10 px of the frame
    parts = neighbour_sources((mx, my), [flow])
    fill_from_neighbours(out, parts, [neighbour])
    assert np.allclose(out[:, :5], scene[:, 5:10], atol=1e-3)
    assert np.all(out[:, 5:] == 0)  # sources inside the frame are left alone
    assert unseen_share(parts, (h, w)) == 0.0
    # 12 columns beyond the edge, the neighbour saw 10 of them: 2 columns none saw, left
    # as the warp filled them, and counted.
    out[:] = -1.0
    parts = neighbour_sources((mx - 7, my), [flow])
    fill_from_neighbours(out, parts, [neighbour])
    assert np.all(out[:, :2] == -1.0) and np.allclose(out[:, 2:12], scene[:, :10], atol=1e-3)
    assert unseen_share(parts, (h, w)) == pytest.approx(2 / w)

def test_neighbour_sources_coarse_test_finds_the_same_pixels():
    # The quick test on the coarse maps must find exactly the full-resolution pixels.
    rng = np.random.default_rng(2)
    cmx = (np.tile(np.arange(40, dtype=np.float32), (30, 1))
           + rng.uniform(-3, 3, (30, 40)).astype(np.float32))
    cmy = (np.tile(np.arange(30, dtype=np.float32)[:, None], (1, 40))
           + rng.uniform(-3, 3, (30, 40)).astype(np.float32))
    full = resize_maps(cmx, cmy, 90, 120)
    # Neighbours 9 px away in all eight directions: every missing pixel lands in one.
    flows = [np.broadcast_to(np.array([dx, dy], np.float32), (30, 40, 2)).copy()
             for dx in (-3, 0, 3) for dy in (-3, 0, 3) if dx or dy]  # 9 px of the plane
    a = neighbour_sources(full, flows)
    b = neighbour_sources(PlaneMaps(cmx, cmy, 90, 120), flows)

    def found(parts):
        return sorted((y, x) for p in parts for y, x in zip(p[1].tolist(), p[2].tolist(),
                                                            strict=True))

    missing = (full[0] < -0.5) | (full[0] > 119.5) | (full[1] < -0.5) | (full[1] > 89.5)
    assert len(found(a)) == missing.sum() > 0
    assert found(a) == found(b)
    for pa, pb in zip(a, b, strict=True):  # the same sources, bit for bit
        assert pa[0] == pb[0] and all(np.array_equal(u, v)
                                      for u, v in zip(pa[1:], pb[1:], strict=True))

def test_neighbour_sources_take_each_row_from_the_neighbour_that_saw_it():
    """Issue 38: beyond the edge, rows read after the reference come from the previous
    frame, rows read before it from the next, whatever the order of the flows; and the
    flow carried past the edge is read a few pixels in (the border's is DIS's least
    sure)."""
    h, w = 40, 60
    mx = np.tile(np.arange(w, dtype=np.float32) - 4, (h, 1))  # 4 columns beyond the left
    my = np.tile(np.arange(h, dtype=np.float32)[:, None], (1, w))
    prev = np.zeros((h, w, 2), np.float32)
    prev[..., 0] = 6.0
    nxt = prev.copy()
    nxt[..., 0] = 9.0
    nxt[:, :2, 0] = -30.0  # the border's own flow: a guess, lands outside
    parts = neighbour_sources((mx, my), [nxt, prev], offsets=[1, -1],
                              reference_row=(h - 1) / 2)
    rows = {k: set(ys.tolist()) for k, ys, _, _, _ in parts if ys.size}
    assert rows[0] == set(range(20)) and rows[1] == set(range(20, h))
    for k, _, xs, nx, _ in parts:
        assert np.allclose(nx - (xs - 4), (9.0, 6.0)[k])


def test_a_source_beyond_the_last_row_goes_on_with_the_motion():
    """A tilt: each row is read later, so the displacement goes on growing past the last
    row, and the maps (the last row's displacement held) put a source beyond it too
    near; moved on by the bottom rows' slope, it is where the motion puts it (the
    diagonal pans' and tilts' strip the previous frame saw, ``benchmarks/edges.py``)."""
    h, w = 60, 80
    rows = np.arange(h, dtype=np.float64)
    v = np.array([0.6, 0.3])  # px a row: right and down
    disp = (rows - h / 2)[:, None] * v  # eq. 26 for a steady camera, reference mid-frame
    mx, my = remap_maps(disp, w)
    slope = edge_slopes(disp)
    assert np.allclose(slope, [v, v])
    low = my > h - 1
    assert low.any()
    sx, sy = beyond_rows(mx[low], my[low], h, slope)
    # The truth: p = s - D(s) with D going on linearly beyond the frame.
    py, px = np.nonzero(low)
    ty = (py - h / 2 * v[1]) / (1 - v[1])
    tx = px + (ty - h / 2) * v[0]
    assert np.allclose(sy, ty, atol=1e-3) and np.allclose(sx, tx, atol=1e-3)
    assert not np.allclose(my[low], ty, atol=1.0)  # held, they were off
    # Rows inside are not moved; a scan the motion outruns is left as it was.
    x, y = beyond_rows(np.array([3.0]), np.array([5.0]), h, slope)
    assert (x[0], y[0]) == (3.0, 5.0)
    x, y = beyond_rows(np.array([3.0]), np.array([65.0]), h, (v, np.array([0.0, 0.95])))
    assert (x[0], y[0]) == (3.0, 65.0)


def test_the_strip_below_a_diagonal_pan_comes_from_where_the_previous_frame_saw_it():
    """A pan of 80 x 48 px a frame (320 x 180, readout 1.0): below the second frame's last
    row, what the previous frame saw (16.4 dB when read with the last row's
    displacement held, along a flow that took the content entering for a global shutter's
    -80 x -48 px; 34.6 now)."""
    from skimage import data

    from unjello.pipeline import correct_frames
    from unjello.simulate import Motion, simulate
    from unjello.timing import SensorTiming
    from unjello.warp.maps import frame_maps

    timing = SensorTiming(1.0)
    sim = list(simulate(data.astronaut(), Motion.steps([(80.0, 48.0)], [100.0]), timing, 2,
                        size=(320, 180)))
    out, _ = correct_frames([s.rolling for s in sim], timing)
    (mx, my), _ = frame_maps(sim[1].motion, 180, 320)
    # beyond the last row; the flow to the previous frame is (-109, -65) px (eq. 10)
    strip = (my > 179.5) & (mx >= 109.1)
    err = (out[1].astype(np.float64) - sim[1].truth)[strip]
    assert strip.sum() > 5000
    assert 10 * np.log10(255.0**2 / np.mean(err**2)) > 32.0
