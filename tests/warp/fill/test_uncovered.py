"""Background a near object uncovered, taken from the neighbour that saw it."""

import numpy as np
import pytest

from unjello.timing import SensorTiming
from unjello.trajectory import FrameMotion
from unjello.warp.fill.uncovered import confirmed, uncovered, uncovered_sources
from unjello.warp.maps import field_maps
from unjello.warp.warper import PictureWarper

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
    # The rows read before the reference: from the next frame, where there is one ...
    nxt = -flow
    both = uncovered(maps, field, [flow, nxt], [-1, 1], reference_row=float(H))
    assert both is not None and np.all(both[2] == 1) and np.all(both[6] == -1)
    # ... and, in a frame with an object moving on its own, where the other one would
    # see it too (confirmed() compares the two).
    both = uncovered(maps, field, [flow, nxt], [-1, 1], reference_row=float(H), lone=True)
    assert both is not None and np.all(both[2] == 1)
    assert np.all(both[6] == 0) and np.allclose(both[7], [8.0, 0.0], atol=0.05)
    # ... and from the previous frame where it is the only one (a pair's second frame)
    # and the frame shows an object moving on its own: it has moved on there too.
    alone = uncovered(maps, field, [flow], [-1], reference_row=float(H), lone=True)
    assert alone is not None and np.all(alone[2] == 0)
    assert np.array_equal(alone[1], found[1])
    assert uncovered(maps, field, [flow], [-1], reference_row=float(H)) is None  # not asked
    # ... and from the previous frame where the next frame's sample leaves its frame (a
    # fast pan carried the background near the side out of it).
    gone = np.full((H, W, 2), [60.0, 0.0], np.float32)
    other = uncovered(maps, field, [flow, gone], [-1, 1], reference_row=float(H))
    assert other is not None and np.all(other[2] == 0)
    assert np.array_equal(other[1], found[1]) and np.allclose(other[3], found[3])
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


@pytest.mark.parametrize(("other", "kept"), [(104.0, 8), (170.0, 0)])
def test_a_fill_both_neighbours_agree_on_is_kept_beside_the_object_itself(other, kept):
    # The pixels beside the band are the object too (250: its own field was the
    # background's, so it gave the displacement), and the neighbour shows 100 where the
    # uncovered points lie: kept where the other neighbour shows the same (within
    # AGREE), not where it shows something else.
    out = np.full((10, 12), 100.0, np.float32)
    out[3:7, 4:12] = 250.0
    ys, xs = (a.ravel() for a in np.mgrid[3:7, 4:6])
    n = ys.size
    found = (ys, xs, np.zeros(n, int), np.zeros((n, 2), np.float32), ys, xs + 4,
             np.ones(n, int), np.zeros((n, 2), np.float32))
    planes = [np.full((10, 12), 100.0, np.float32), np.full((10, 12), other, np.float32)]
    got = confirmed(found, (10, 12), out, planes)
    assert (0 if got is None else got[0].size) == kept
    # Without a second view, the object beside it is what the output is compared with.
    assert confirmed(found[:6], (10, 12), out, planes[:1]) is None


@pytest.mark.parametrize(("seen", "far_shown", "kept"),
                         [(100.0, False, 8), (250.0, False, 0), (100.0, True, 0)])
def test_a_donor_on_a_fitted_object_is_compared_on_the_other_side(seen, far_shown, kept):
    # The donors (4 px on) lie on a fitted pole (250, shown) whose motion was near the
    # background's; the background (100) lies as far on the other side. The neighbour
    # shows `seen` where the uncovered points lie: its background is kept, compared with
    # the other side, unless that side shows an object too.
    out = np.full((10, 12), 100.0, np.float32)
    out[3:7, 4:12] = 250.0
    shown = np.zeros((10, 12), bool)
    shown[:, 6:12] = True
    shown[:, :4] = far_shown
    ys, xs = (a.ravel() for a in np.mgrid[3:7, 4:6])
    n = ys.size
    found = (ys, xs, np.zeros(n, int), np.zeros((n, 2), np.float32), ys, xs + 4)
    neighbour = np.full((10, 12), seen, np.float32)
    got = confirmed(found, (10, 12), out, [neighbour], shown)
    assert (0 if got is None else got[0].size) == kept
    # Without the objects, the pole beside it is what the output is compared with.
    assert confirmed(found, (10, 12), out, [neighbour]) is None


def test_uncovered_reads_in_this_frame_a_map_that_went_to_the_object_beside_it():
    """Output columns 23-24 show background whose source (26-27, left of the pole) this
    frame saw, but their maps went to the pole's sources (31-32: the fixed point of a
    field that jumps at the pole's edge can). With ``here`` they are read in this frame
    at the background's displacement, as the flow index after the last."""
    _, _, _, field = _layers()
    mx, my = (m.copy() for m in field_maps(field))
    mx[:, 23:25] += 5.0  # sources 31-32: the pole's
    flow = np.zeros((H, W, 2), np.float32)
    flow[..., 0] = 5.0
    found = uncovered((mx, my), field, [flow], [-1], reference_row=0.0, here=True)
    assert found is not None
    ys, xs, k, delta = found[:4]
    mine = k == 1
    assert set(xs[mine].tolist()) == {23, 24} and np.allclose(delta[mine], [3.0, 0.0])
    assert np.all(found[6][mine] == -1)  # no second view
    without = uncovered((mx, my), field, [flow], [-1], reference_row=0.0)
    assert without is None or not np.isin(without[1], [23, 24]).any()
