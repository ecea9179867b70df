"""What a frame did not see beyond its edge, taken from its neighbours."""

import numpy as np
import pytest

from unjello.map_bands import PlaneMaps
from unjello.neighbours import fill_from_neighbours, neighbour_sources, unseen_share
from unjello.warp import resize_maps


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
