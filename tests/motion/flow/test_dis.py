"""The optical-flow toolkit: large motion, row flows, sharpening at motion boundaries."""

import cv2
import numpy as np
import pytest

from unjello.motion.flow.dis import ROW_AGREE, median_along, optical_flow, row_flows, textured
from unjello.motion.flow.patches import refine_motion_edges

from ...clips import pole_pan


def test_refine_motion_edges_undoes_flow_bleeding():
    # A textured square moved 6 px right over a still textured background; the flow
    # given is the true one blurred across the square's edge (as DIS smooths it). Near
    # the edge the refined flow must be at least 3x closer to the truth.
    rng = np.random.default_rng(1)
    h, w = 96, 128
    prev = cv2.GaussianBlur(rng.random((h, w)).astype(np.float32) * 255, (0, 0), 1.0)
    square = cv2.GaussianBlur(rng.random((h, w)).astype(np.float32) * 255, (0, 0), 1.0)
    inside = np.zeros((h, w), bool)
    inside[30:66, 40:80] = True
    prev = np.where(inside, square, prev).astype(np.float32)
    cur = prev.copy()
    moved = np.roll(inside, 6, axis=1)
    cur[moved] = np.roll(square, 6, axis=1)[moved]
    truth = np.zeros((h, w, 2), np.float32)
    truth[moved, 0] = -6.0  # cur(s) = prev(s + flow)
    given = cv2.GaussianBlur(truth, (0, 0), 4.0)
    near = (cv2.dilate(moved.astype(np.uint8), np.ones((9, 9))) > 0) & ~(
        cv2.erode(moved.astype(np.uint8), np.ones((9, 9))) > 0)
    err_in = np.abs(given - truth)[near].mean()
    err_out = np.abs(refine_motion_edges(cur, prev, given) - truth)[near].mean()
    assert err_out < err_in / 3


def _textured(size=(240, 560)):
    from skimage import data

    grass = data.grass().astype(np.float32)
    return np.ascontiguousarray(grass[:size[0], :size[1]])


def test_a_whip_pan_over_grass_is_followed_not_aliased():
    # 18 % of a 320 px frame per frame: DIS from zero locks onto an alias of the grass.
    scene = _textured()
    a, b = scene[:, 58:378], scene[:, :320]  # a(s) = b(s + (58, 0))
    flow = optical_flow(a, b, "medium", 0, None, 1)
    inner = flow[20:-20, 20:-80]  # what stays in view
    assert np.median(np.abs(inner[..., 0] - 58.0)) < 0.5
    assert np.mean(np.abs(inner[..., 0] - 58.0) < 1.0) > 0.9


def test_a_fast_pan_over_a_flat_sky_is_followed_where_the_correlation_peak_is_weak():
    """40 % of the width a frame over the rocket's flat sky, the tower leaving the frame.

    Phase correlation finds the shift but with a weak peak; DIS from zero follows nothing
    (-10 px where the scene moves -128). The second start is used because it matches
    the frame better as a whole.
    """
    from skimage import data

    from unjello.motion.flow.dis import global_shifts, row_flows
    from unjello.simulate import Motion, simulate
    from unjello.timing import SensorTiming

    sim = list(simulate(data.rocket(), Motion("pan", speed=128.0), SensorTiming(0.7), 10,
                        size=(320, 180)))
    prev, cur = (cv2.cvtColor(s.rolling, cv2.COLOR_RGB2GRAY) for s in sim[:2])
    shift, response = global_shifts(cur, prev)[-1]
    assert response < 0.1 and abs(shift[0] + 128) < 5  # the case this test is about
    flow = optical_flow(cur, prev, "medium", 480, 1, 3, 2)
    rows = row_flows(flow, np.ones(flow.shape[:2], bool))[1]
    assert np.mean(np.abs(rows[:, 0] + 128.0) < 2.0) > 0.9


def test_a_second_run_that_matches_worse_as_a_whole_is_not_used():
    from unjello.motion.flow.dis import _pick_by_cost

    scene = _textured()
    a, b = scene[:, 10:330], scene[:, :320]  # a(s) = b(s + (10, 0))
    right = np.zeros(a.shape + (2,), np.float32)
    right[..., 0] = 10.0
    wrong = right.copy()
    wrong[:, 40:, 0] = 37.0  # right on a strip only: better there, worse as a whole
    picked = _pick_by_cost(a, b, wrong, right, whole="mean")
    assert np.array_equal(picked[:, 60:-60], right[:, 60:-60])
    assert _pick_by_cost(a, b, right, wrong, whole="mean") is right
    mixed = _pick_by_cost(a, b, right, wrong)  # per pixel: the wrong one nowhere better
    assert np.array_equal(mixed[:, 60:-60], right[:, 60:-60])


def test_over_the_whole_frame_the_median_goes_by_the_scene_not_what_left_it():
    from unjello.motion.flow.dis import _pick_by_cost

    # A faint scene (a 20th of the grass's contrast) that moved 10 px, and on the right
    # a bright patch that left: what the frame shows there now is the old frame 37 px
    # on (an alias). The true motion matches most of the frame; the alias that patch.
    scene = _textured()
    b = scene[:, :320] * 0.05 + 100.0
    a = scene[:, 10:330] * 0.05 + 100.0
    a[:, 220:280] = scene[:, 257:317]
    b[:, 257:317] = scene[:, 257:317]
    right = np.zeros(a.shape + (2,), np.float32)
    right[..., 0] = 10.0
    alias = right.copy()
    alias[..., 0] = 37.0
    # The patch's cost rules the mean: the alias wins it, over the frame as a whole.
    assert _pick_by_cost(a, b, right, alias, whole="mean") is not right
    assert _pick_by_cost(a, b, alias, right, whole="mean") is alias
    # By the median, the scene's motion wins, and only the patch keeps the alias.
    assert _pick_by_cost(a, b, right, alias, whole="median") is right
    picked = _pick_by_cost(a, b, alias, right, whole="median")
    assert np.array_equal(picked[20:-20, 20:200], right[20:-20, 20:200])


def test_small_motion_is_plain_dis():
    """The second start never fires below LARGE_MOTION: the flow is DIS's own."""
    scene = _textured()
    a, b = scene[:, 10:330], scene[:, :320]  # 3 % of the width
    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
    dis.setFinestScale(0)
    dis.setVariationalRefinementIterations(1)
    plain = dis.calc(a.astype(np.uint8), b.astype(np.uint8), None)
    assert np.array_equal(optical_flow(a, b, "medium", 0, None, 1), plain)


def test_a_reused_flow_engine_gives_what_a_fresh_one_gives():
    """DIS instances are kept per thread: a pair's flow must not depend on the pairs before.

    OpenCV's DIS, once given a starting flow, uses it again on later calls without one; a
    whip pan (second start) followed by a small motion, a smaller copy, then the small
    motion again must each match a DIS made for it alone.
    """
    scene = _textured()
    whip = scene[:, 58:378], scene[:, :320]
    small = scene[:, 10:330], scene[:, :320]
    half = scene[::2, 10:330:2], scene[::2, :320:2]

    def fresh(a, b):
        dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
        dis.setFinestScale(0)
        dis.setVariationalRefinementIterations(1)
        return dis.calc(a.astype(np.uint8), b.astype(np.uint8), None)

    optical_flow(*whip, "medium", 0, None, 1)
    for a, b in (small, half, small):
        assert np.array_equal(optical_flow(a, b, "medium", 0, None, 1), fresh(a, b))


def test_polished_flow_is_as_close_as_the_full_one():
    # DIS down to half resolution, polished at full: within 0.05 px of the full-resolution
    # flow's error on a sub-pixel shift of a textured scene (both well under 0.2 px).
    scene = cv2.GaussianBlur(_textured((260, 380)), (0, 0), 1.0)
    shift = np.float32([[1, 0, -2.3], [0, 1, 1.6]])  # a(s) = scene(s + (2.3, -1.6))
    a = cv2.warpAffine(scene, shift, (380, 260), flags=cv2.INTER_CUBIC)[10:-10, 10:-10]
    b = scene[10:-10, 10:-10]
    inner = (slice(12, -12), slice(12, -12))
    truth = np.array([2.3, -1.6], np.float32)

    def error(flow):
        return float(np.abs(flow[inner] - truth).mean())

    full = error(optical_flow(a, b, "medium", 0, 0, 1))
    polished = error(optical_flow(a, b, "medium", 0, 1, 3, polish=3))
    coarse = error(optical_flow(a, b, "medium", 0, 1, 3))
    assert polished < 0.2 and full < 0.2
    assert polished < full + 0.05
    assert polished < coarse


def _pair(scene_kind):
    """Two grey frames of a simulated 320 x 240 pan over the astronaut, with a scene."""
    from skimage import data

    from unjello.simulate import Motion, simulate
    from unjello.timing import SensorTiming

    sim = list(simulate(data.astronaut(), Motion("pan", speed=5.0), SensorTiming(1.0), 2,
                        size=(320, 240), layers=scene_kind, layer_image=data.coffee()))
    return [s.rolling.mean(axis=2).astype(np.float32) for s in sim]


def test_the_checked_flow_is_polished_unless_that_misses_a_spinner():
    # The polished flow passes a spinning wheel's blades as consistent (a smooth wrong
    # motion): the checked flow sees the pixels it carries onto unlike grey levels and
    # measures that pair at full detail; a plain pan keeps the polished flow.
    from unjello.motion.dense.config import DenseConfig
    from unjello.motion.flow.dis import explains, flow_pair

    checked, polished = (DenseConfig(detail=d).flow for d in ("checked", "polished"))
    full = DenseConfig(detail="full").flow
    assert checked.fallback == full and polished.fallback is None
    for kind, explained in (("planar", True), ("wheel", False)):
        prev, cur = _pair(kind)
        smooth = flow_pair(prev, cur, polished)
        assert explains(prev, cur, smooth[0]) is explained
        expected = smooth if explained else flow_pair(prev, cur, full)
        got = flow_pair(prev, cur, checked)
        assert all(np.array_equal(a, b) for a, b in zip(got, expected, strict=True))


def test_misses_are_where_the_flow_lands_on_unlike_grey_levels():
    import cv2

    from unjello.motion.flow.dis import misses

    rng = np.random.default_rng(1)
    b = cv2.GaussianBlur(rng.uniform(0, 255, (60, 80)).astype(np.float32), (0, 0), 1)
    a = np.roll(b, -3, axis=1)  # a(s) = b(s + (3, 0))
    flow = np.zeros((60, 80, 2), np.float32)
    flow[..., 0] = 3
    flow[20:40, 30:50] = 0  # a patch it does not follow
    found = misses(b, a, flow)
    assert found[25:35, 35:45].mean() > 0.8
    assert not found[:10, :72].any()  # followed
    assert not found[:, 77:].any()  # landing outside the frame: not counted


def _flagpole_pan():
    """40 % of the width a frame, readout 0.7, over the rocket's flat sky with a white pole
    as far as the sky (benchmarks/edges.py --near 1.0001), 320x180: 10 frames, the poles."""
    from skimage import data

    return pole_pan(data.rocket(), 0.4, 0.7, near=1.0001)


def test_a_fast_pan_the_correlation_misses_is_followed_from_the_expected_shift(monkeypatch):
    """Frame 6 of the flagpole pan: the tower enters, the rocket leaves, a pole over the
    sky between. The cyclic phase correlation finds +134 px where the scene moves -128
    (its peaks checked where the copies overlap find -130 as well), and DIS from there
    follows nothing (row medians -5 to +11 px); started from the pace of the pair before
    (``expect``) it follows the pan. The overlap's shift is left out here to test that."""
    from unjello.motion.flow import dis as flow_module
    from unjello.motion.flow.dis import global_shifts, row_flows

    sim, _ = _flagpole_pan()
    prev, cur = (cv2.cvtColor(s.rolling, cv2.COLOR_RGB2GRAY) for s in sim[5:7])
    shifts = global_shifts(cur, prev)
    assert abs(shifts[0][0][0] + 128) > 50  # the case this test is about
    assert abs(shifts[-1][0][0] + 128) < 4.0
    monkeypatch.setattr(flow_module, "global_shifts", lambda a, b: global_shifts(a, b)[:1])
    ok = np.ones(cur.shape, bool)
    lost = row_flows(optical_flow(cur, prev, "medium", 0, None, 1, 2), ok)[1]
    assert np.mean(np.abs(lost[:, 0] + 128.0) < 2.0) < 0.5
    flow = optical_flow(cur, prev, "medium", 0, None, 1, 2, expect=np.array([-128.0, 0.0]))
    rows = row_flows(flow, ok)[1]
    assert np.mean(np.abs(rows[:, 0] + 128.0) < 2.0) > 0.9


@pytest.mark.parametrize("n", [1, 2, 79, 80, 120])
def test_median_along_is_numpys_median(n):
    rng = np.random.default_rng(n)
    values = rng.normal(0, 5, (27, n, 2)).astype(np.float32)
    values[:, : n // 3] = values[:, :1]  # ties
    for axis in (0, 1, 2):
        want = np.median(values, axis=axis)
        got = median_along(values, axis)
        assert got.dtype == want.dtype
        np.testing.assert_array_equal(got, want)
    flat = values.ravel().astype(np.float64)
    assert median_along(flat) == np.median(flat)


def test_a_row_weighs_the_pixels_that_agree_with_its_flow():
    """Content entering the frame, or a flat region, passes the consistency check with a
    flow of its own: with ``agree`` its row weighs the pixels that move as the row does."""
    rng = np.random.default_rng(0)
    flow = np.zeros((40, 200, 2), np.float32)
    flow[..., 0] = -30.0
    flow[:10, :120, 0] = rng.uniform(-8.0, 8.0, (10, 120))  # scattered, all "reliable"
    ok = np.ones((40, 200), bool)
    ok[30:, ::2] = False  # half unreliable: half the weight either way
    _, med, plain = row_flows(flow, ok)
    _, med_agree, weight = row_flows(flow, ok, ROW_AGREE)
    np.testing.assert_array_equal(med, med_agree)
    assert np.all(plain[:30] == 1.0) and np.allclose(plain[30:], 0.5)
    assert np.all(weight[:10] < 0.6) and np.all(weight[10:30] == 1.0)
    assert np.allclose(weight[30:], 0.5)


def test_a_still_textured_background_beside_a_crossing_object_keeps_still():
    # A still camera; a photo as high as the frame crosses the rocket on its pad at 30 px
    # a frame (readout 1.0). DIS's coarse levels took the object's motion for the
    # background beside it, and the launch tower's lattice matched one period off: 16-37 %
    # of the background's textured pixels moved over 2 px in the last three pairs. Zero
    # motion matches them far better, over the whole tower. The flat sky between the
    # right-hand tower's bars, as good under zero motion as under the object's, keeps
    # still with it: 35-49 % of the right quarter's background moved over 1 px.
    from unjello.simulate.matrix import build, cases

    case = next(c for c in cases() if c.name == "still/tall/rocket-30px")
    clip = build(case)
    grey = [cv2.cvtColor(np.clip(f, 0, 255).astype(np.uint8), cv2.COLOR_RGB2GRAY)
            .astype(np.float32) for f in clip.rolling]
    for k in (8, 9, 10):
        flow = optical_flow(grey[k + 1], grey[k])
        still = clip.background[k + 1] & textured(grey[k + 1])
        assert still.sum() > 10000
        assert np.mean(np.hypot(*flow[still].T) > 2.0) < 0.02, k
        right = clip.background[k + 1].copy()
        right[:, :3 * right.shape[1] // 4] = False
        assert np.mean(np.hypot(*flow[right].T) > 1.0) < 0.15, k


def test_textured_is_two_dimensional_texture_only():
    """Along an edge the flow is filled in, not measured: edges and flat areas are left out."""
    img = np.zeros((60, 80), np.float32)
    img[:, 40:] = 200.0  # one upright edge
    rng = np.random.default_rng(0)
    img[10:30, 5:25] = rng.uniform(0, 255, (20, 20))  # a patch of texture
    mask = textured(img)
    assert mask[12:28, 7:23].mean() > 0.9
    assert not mask[35:, 30:50].any()  # the edge, away from the patch
    assert not mask[40:, 50:].any()  # flat
