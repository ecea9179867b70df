"""What a frame did not see, taken from its neighbours: beyond its edge, behind a near object."""

import numpy as np
import pytest

from unjello.neighbours import (
    confirmed,
    fill_from_neighbours,
    neighbour_sources,
    uncovered,
    uncovered_sources,
    unseen_share,
)
from unjello.timing import SensorTiming
from unjello.trajectory import FrameMotion
from unjello.warp import PictureWarper, field_maps, resize_maps


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
    b = neighbour_sources(full, flows, coarse=(cmx, cmy))

    def found(parts):
        return sorted((y, x) for p in parts for y, x in zip(p[1].tolist(), p[2].tolist(),
                                                            strict=True))

    missing = (full[0] < -0.5) | (full[0] > 119.5) | (full[1] < -0.5) | (full[1] > 89.5)
    assert len(found(a)) == missing.sum() > 0
    assert found(a) == found(b)

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


H, W = 24, 64
POLE = slice(30, 36)  # the near object's columns in this frame


def _layers() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A pan (background displaced 3 px) behind a flat pole displaced -1 px (parallax).

    Output pixel ``p`` takes source ``p + D``: the background's ``D = 3``, so the pole
    (sources 30-35) lands on 31-36, and output 27-30 shows background whose source (30-33)
    the pole covers in this frame. The previous frame saw it 5 px further right.
    Returns the reference picture, this frame, the previous frame and the field.
    """
    rng = np.random.default_rng(3)
    scene = rng.uniform(40, 160, (H, W + 20)).astype(np.float32)
    ref = scene[:, :W].copy()  # the background at the reference time
    frame = np.empty((H, W), np.float32)
    frame[:, 3:] = ref[:, :W - 3]  # I(s) = ref(s - 3)
    frame[:, :3] = scene[:, W:W + 3]
    frame[:, POLE] = 250.0
    prev = np.empty((H, W), np.float32)
    prev[:, 8:] = ref[:, :W - 8]  # prev(x) = ref(x - 8): this frame's flow to it is +5
    prev[:, :8] = scene[:, W + 3:W + 11]
    field = np.zeros((H, W, 2), np.float32)
    field[..., 0] = 3.0  # p = s - field(s): the background's source 3 px right
    field[:, POLE, 0] = -1.0  # the pole's 1 px left
    return ref, frame, prev, field


def test_uncovered_finds_what_the_pole_covered_and_where_the_neighbour_saw_it():
    _, _, _, field = _layers()
    maps = field_maps(field)
    flow = np.zeros((H, W, 2), np.float32)
    flow[..., 0] = 5.0
    found = uncovered(maps, field, [flow], [-1], reference_row=0.0)
    assert found is not None
    ys, xs, k, delta = found[:4]
    cols = set(xs.tolist())
    assert {28, 29} <= cols <= set(range(26, 32))  # output 27-30, a pixel of blur either side
    assert np.all(k == 0)
    assert np.allclose(delta, [8.0, 0.0], atol=0.05)  # background's 3 px and the flow's 5
    # No neighbour for the rows read before the reference (the next frame saw them):
    assert uncovered(maps, field, [flow], [-1], reference_row=float(H)) is None
    # Without parallax nothing is uncovered.
    flat = np.full((H, W, 2), 3.0, np.float32)
    flat[..., 1] = 0.0
    assert uncovered(field_maps(flat), flat, [flow], [-1], 0.0) is None


def test_the_warper_takes_the_uncovered_background_from_the_previous_frame():
    ref, frame, prev, field = _layers()
    flow = np.zeros((H, W, 2), np.float32)
    flow[..., 0] = 5.0
    d = np.zeros((H, 2))
    motion = FrameMotion(0, 0.0, d, np.zeros((H, 2)), field=field, neighbours=((-1, flow),))
    warper = PictureWarper(SensorTiming(0.5, reference="first"))
    out = warper([frame], motion, {-1: [prev]})[0]
    alone = warper([frame], motion)[0]  # no neighbour: the pole stretched over it
    gap = (slice(2, H - 2), slice(27, 30))
    assert np.abs(alone[gap] - ref[gap]).mean() > 40
    assert np.abs(out[gap] - ref[gap]).mean() < 2
    # The pole and the background elsewhere as before.
    rest = np.ones(W, bool)
    rest[26:31] = False
    assert np.array_equal(out[:, rest], alone[:, rest])


def test_uncovered_sources_cover_each_grid_pixels_block_of_the_plane():
    found = (np.array([1]), np.array([2]), np.array([0]), np.array([[1.5, -0.5]], np.float32))
    (k, ys, xs, nx, ny), = uncovered_sources(found, (4, 5), (8, 10))
    assert sorted(zip(ys.tolist(), xs.tolist(), strict=True)) == [(2, 4), (2, 5), (3, 4), (3, 5)]
    assert k == 0
    assert np.allclose(nx - xs, 3.0) and np.allclose(ny - ys, -1.0)


@pytest.mark.parametrize(("seen", "kept"), [(100.0, 8), (250.0, 0)])
def test_a_fill_is_kept_only_where_it_looks_like_the_background(seen, kept):
    # Output 250 (the pole stretched) on a 4 x 2 band, background 100 beside it; the
    # neighbour shows `seen` where the uncovered points lie.
    out = np.full((10, 12), 100.0, np.float32)
    out[3:7, 4:6] = 250.0
    neighbour = np.full((10, 12), seen, np.float32)
    ys, xs = (a.ravel() for a in np.mgrid[3:7, 4:6])
    n = ys.size
    found = (ys, xs, np.zeros(n, int), np.zeros((n, 2), np.float32), ys, xs + 4)
    got = confirmed(found, (10, 12), out, [neighbour])
    assert (0 if got is None else got[0].size) == kept
    # A single pixel is a speck, not an object's edge uncovered.
    one = tuple(a[:1] for a in found)
    assert confirmed(one, (10, 12), out, [np.full((10, 12), 100.0, np.float32)]) is None
