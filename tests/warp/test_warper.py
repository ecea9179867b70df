import numpy as np
import pytest

from unjello.timing import SensorTiming, scanline_displacement
from unjello.warp.maps import field_maps, resize_maps
from unjello.warp.warper import PictureWarper, fill_holes, remap, resample_displacement, splat


@pytest.fixture
def image(scene):
    return scene[100:196, 120:248].copy()


def test_zero_displacement_is_identity(image):
    zero = np.zeros((image.shape[0], 2))
    out_r, valid_r = remap(image, zero)
    out_s, valid_s = splat(image, zero)
    assert np.array_equal(out_r, image) and valid_r.all()
    assert np.abs(out_s.astype(int) - image).max() <= 1 and valid_s.all()


@pytest.mark.parametrize("rho, reference", [(1.0, "middle"), (0.6, "middle"), (0.6, "first")])
def test_eq26_constant_velocity(rho, reference):
    h = 101
    timing = SensorTiming(rho, reference=reference)
    v = np.tile([4.0, -2.0], (h, 1))
    d = scanline_displacement(v, timing)
    t = timing.row_times(h)
    expected = np.outer(t - timing.reference_time(h), [4.0, -2.0])
    assert np.allclose(d, expected, atol=1e-9)


def test_eq26_linear_velocity():
    # v(t) = a + b t  ->  integral from t_ref to t = a (t - t_ref) + b/2 (t^2 - t_ref^2).
    h, rho = 200, 0.8
    timing = SensorTiming(rho)
    t = timing.row_times(h, start=3.0)
    a, b = 2.0, 5.0
    v = np.stack([a + b * t, np.zeros(h)], axis=1)
    d = scanline_displacement(v, timing)
    tr = timing.reference_time(h, start=3.0)
    exact = a * (t - tr) + b / 2 * (t**2 - tr**2)
    assert np.allclose(d[:, 0], exact, atol=1e-4)


def test_splat_and_remap_agree_on_smooth_shift(image):
    h = image.shape[0]
    disp = np.stack([np.linspace(-3.3, 3.3, h), np.linspace(-1.2, 1.2, h)], axis=1)
    a, va = remap(image, disp, fill="black")
    b, vb = splat(image, disp, fill="black")
    both = va & vb
    both[:4] = both[-4:] = False
    both[:, :5] = both[:, -5:] = False
    diff = np.abs(a.astype(float) - b.astype(float))[both]
    assert diff.mean() < 4.0


def test_remap_moves_content_by_minus_displacement():
    img = np.zeros((40, 60), np.float32)
    img[20, 30] = 1.0
    disp = np.tile([5.0, 0.0], (40, 1))  # p = s - Delta: the dot moves 5 px left
    out, _ = remap(img, disp, fill="black")
    assert np.unravel_index(out.argmax(), out.shape) == (20, 25)
    out_s, _ = splat(img, disp, fill="black")
    assert np.unravel_index(out_s.argmax(), out_s.shape) == (20, 25)


def test_fill_modes():
    img = np.ones((10, 10), np.float32)
    valid = np.ones((10, 10), bool)
    valid[:, :3] = False
    valid[5, 6] = False  # a crack
    black = fill_holes(img, valid, "black")
    assert black[5, 6] == 1.0 and black[:, :3].max() == 0.0
    near = fill_holes(img, valid, "nearest")
    assert near.min() == 1.0


def test_resample_displacement_for_chroma():
    d = np.stack([np.linspace(0, 10, 100), np.zeros(100)], axis=1)
    c = resample_displacement(d, 50, 0.5, 0.5)
    assert c.shape == (50, 2)
    assert c[0, 0] == pytest.approx(0.5 * np.interp(0.5, np.arange(100), d[:, 0]))


def test_the_warper_says_what_no_frame_saw():
    """PictureWarper.unseen: the share of the output beyond the edge no neighbour gave."""
    from unjello.trajectory import FrameMotion

    h, w = 40, 60
    d = np.zeros((h, 2))
    d[:, 0] = 6.0  # every row shifted 6 px: 6 columns beyond the edge
    fm = FrameMotion(0, 0.0, d, np.zeros((h, 2)))
    warper = PictureWarper(SensorTiming(1.0))
    warper([np.zeros((h, w), np.uint8)], fm)
    assert warper.unseen == pytest.approx(6 / w)
    field = np.zeros((h, w, 2), np.float32)
    field[..., 0] = 6.0
    flow = np.zeros((h, w, 2), np.float32)
    flow[..., 0] = -4.0  # the neighbour saw 4 of them
    fm = FrameMotion(0, 0.0, d, np.zeros((h, 2)), field=field, neighbours=((-1, flow),))
    warper([np.zeros((h, w), np.uint8)], fm, {-1: [np.zeros((h, w), np.uint8)]})
    assert warper.unseen == pytest.approx(2 / w)


def test_field_maps_on_a_coarse_grid_take_frame_pixels():
    # A field sampled on a grid a third of the frame's size, its values in frame pixels
    # (as the dense method returns it): a shift of 6 px is 2 px of that grid.
    field = np.broadcast_to(np.array([6.0, -3.0], np.float32), (20, 30, 2))
    mx, my = field_maps(field, frame=(60, 90))
    assert np.allclose(mx - np.arange(30), 2.0) and np.allclose(my.T - np.arange(20), -1.0)
    fx, fy = resize_maps(mx, my, 60, 90)
    # Up to the frame's edges: beyond the outermost samples the displacement is held (the
    # source position held would smear the edge pixels, as cv2.resize alone did).
    assert np.allclose(fx - np.arange(90), 6.0, atol=1e-4)
    assert np.allclose(fy - np.arange(60)[:, None], -3.0, atol=1e-4)


def test_a_front_layer_shows_the_turned_object_where_it_lands():
    """A bar turned back by its rotation lands partly on what the frame shows as
    background; the forward field alone finds that background there (the bar's tip is
    cut off), the front layer finds the bar."""
    import cv2

    from unjello.motion.objects.spinners import Spin, spin_field, spin_source
    from unjello.trajectory import FrameMotion
    from unjello.warp.maps import frame_maps

    h, w = 80, 100
    yy, xx = np.mgrid[0:h, 0:w]
    bar = (np.abs(xx - 50) < 4) & (np.abs(yy - 40) < 35)  # the object, upright
    image = np.where(bar, 200.0, 50.0).astype(np.float32)

    def still(t):
        return np.zeros((np.asarray(t).size, 2))

    spin = Spin(np.array([50.0, 40.0]), 0.6, 1.0, 5.0)  # turned back by up to 0.3 rad
    rotation = spin_field(spin, (h, w), still, 0.5, 1.0)
    weight = bar.astype(np.float32)
    field = (rotation * weight[..., None]).astype(np.float32)  # background: no motion
    front = np.dstack([spin_source(spin, (h, w), still, 0.5, 1.0), weight])
    alone = FrameMotion(0, 0.0, np.zeros((h, 2)), np.zeros((h, 2)), field=field)
    layered = FrameMotion(0, 0.0, np.zeros((h, 2)), np.zeros((h, 2)), field=field,
                          front=(front,))
    # Where the turned bar's ends land: s - D(s) for its pixels.
    p = np.stack([xx, yy], axis=-1)[bar] - rotation[bar]
    lands = np.zeros((h, w), bool)
    lands[np.clip(np.round(p[:, 1]).astype(int), 0, h - 1),
          np.clip(np.round(p[:, 0]).astype(int), 0, w - 1)] = True
    tips = lands & ~cv2.dilate(bar.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    assert tips.sum() > 20

    def shown(motion):
        mx, my = frame_maps(motion, h, w)[0]
        return cv2.remap(image, mx, my, cv2.INTER_LINEAR)

    assert shown(alone)[tips].mean() < 100  # cut off: the background (measured 50)
    assert shown(layered)[tips].mean() > 170  # the bar (measured 178; its edge 50-164)


def test_undistorting_reads_the_same_in_every_scan_direction(scene):
    """--undistort is composed with the correction's maps in the frames' top-bottom
    orientation; the fisheye model is radial, so with no motion every scan direction
    gives the input undistorted in its own orientation, in one resampling."""
    import cv2

    from unjello.lens import Lens
    from unjello.timing import DIRECTIONS, to_top_bottom
    from unjello.trajectory import FrameMotion
    from unjello.warp.warper import PictureWarper, apply_maps

    lens = (0.06, 0.03, -0.005, 0.002)
    img = cv2.resize(scene, (160, 120))
    expected = apply_maps(img, Lens(110.0, lens).undistortion_maps((120, 160)))
    for direction in DIRECTIONS:
        h = to_top_bottom(img, direction).shape[0]
        still = FrameMotion(0, 0.0, np.zeros((h, 2)), np.zeros((h, 2)))
        warper = PictureWarper(SensorTiming(1.0, direction), undistort=Lens(110.0, lens))
        out = warper([img], still)[0]
        assert out.shape == img.shape
        assert np.abs(out.astype(int) - expected).max() <= 1, direction


def test_a_layer_s_soft_edge_takes_one_source_where_the_two_are_far_apart():
    """A near pole's layer carries its pixels 40 px; its weight fades over its edge. A
    position between the background's source and the pole's is neither: at such a
    pixel the map takes the source of more weight. Sources a pixel apart still blend."""
    from unjello.timing import pixel_grid
    from unjello.warp.maps import FRONT_BLEND, front_maps

    h, w = 4, 80
    gx, gy = pixel_grid(h, w)
    weight = np.clip((np.arange(w, dtype=np.float32) - 50.0) / 8.0, 0.0, 1.0)  # a soft edge
    for shift in (40.0, 0.5 * FRONT_BLEND):
        layer = np.zeros((h, w, 3), np.float32)
        layer[..., 0] = shift
        layer[..., 2] = weight
        mx, _ = front_maps((gx, gy), layer)
        d = mx[0] - gx[0]  # 0: the maps' source, ``shift``: the layer's
        # the weight sampled where the layer lands, nothing beyond the frame (0 past it)
        lands = np.interp(np.arange(w) + shift, np.arange(w + 1), np.append(weight, 0.0))
        if shift > FRONT_BLEND:
            assert set(np.round(d, 4).tolist()) <= {0.0, shift}
            np.testing.assert_array_equal(d == shift, lands >= 0.5)
        else:
            np.testing.assert_allclose(d, lands * shift, atol=0.01)  # remap: 1/32 px steps
