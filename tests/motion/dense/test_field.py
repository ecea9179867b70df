"""The flow-field helpers: masked copies, the projective fit, the residual carried to the
reference time."""

import cv2
import numpy as np

from unjello.motion.dense.field import (
    at_reference,
    both_axes,
    fill_unreliable,
    fit_projective,
    projective_flow,
    put,
    snap_to_camera,
)
from unjello.timing import pixel_grid


def test_put_and_both_axes_match_their_numpy_forms():
    rng = np.random.default_rng(0)
    dst = rng.random((27, 48, 2), dtype=np.float32)
    src = rng.random((27, 48, 2), dtype=np.float32)
    where = rng.random((27, 48)) < 0.5
    expected = dst.copy()
    np.copyto(expected, src, where=where[..., None])
    put(dst, src, where)
    assert np.array_equal(dst, expected)
    f64 = dst.astype(np.float64)  # another dtype: NumPy's copy, still in place
    put(f64, src.astype(np.float64) + 1, ~where)
    assert np.array_equal(f64[~where], src[~where].astype(np.float64) + 1)
    values = rng.random((27, 48), dtype=np.float32)
    assert np.array_equal(both_axes(values) * src, values[..., None] * src)


def test_at_reference_is_exact_for_a_quadratic_motion():
    # r(e) = a e + b e^2 on both sides (r(0) = 0 at the pixel's own time): the quadratic
    # gives r at the reference exactly; one side alone gives the straight line.
    rng = np.random.default_rng(1)
    h, w = 20, 30
    a, b = rng.normal(size=(h, w, 2)), rng.normal(size=(h, w, 2))
    ea = -1 + 0.2 * rng.random((h, w))
    eb = 1 + 0.2 * rng.random((h, w))
    ahead = 0.3 * rng.random((h, 1)) - 0.15

    def r(e):
        return (a * e[..., None] + b * e[..., None] ** 2).astype(np.float32)

    ok = np.ones((h, w), bool)
    only_a = rng.random((h, w)) < 0.3
    field, fallback = at_reference(
        [(ea.astype(np.float32), r(ea), ok), (eb.astype(np.float32), r(eb), ~only_a)],
        ahead.astype(np.float32))
    truth = r(np.broadcast_to(ahead, (h, w)))
    assert not fallback.any()
    assert np.abs(field - truth)[~only_a].max() < 1e-4
    line = (ahead / ea)[..., None] * r(ea)
    assert np.abs(field - line)[only_a].max() < 1e-4


def test_unreliable_pixels_far_from_reliable_ones_take_the_prior():

    resid = np.zeros((60, 200, 2), np.float32)
    resid[..., 0] = 3.0
    ok = np.zeros((60, 200), bool)
    ok[:, 120:] = True  # the left 120 columns unreliable
    prior = np.zeros((60, 1, 2), np.float32)
    prior[:, 0, 0] = 5.0
    plain = fill_unreliable(resid.copy(), ok, 12.0)
    given = fill_unreliable(resid.copy(), ok, 12.0, prior=prior)
    assert np.allclose(plain[:, 110:, 0], 3.0) and np.allclose(given[:, 110:, 0], 3.0)
    assert np.allclose(plain[:, :40, 0], 0.0) and np.allclose(given[:, :40, 0], 5.0)
    assert np.array_equal(plain[:, 104:], given[:, 104:])  # near reliable pixels: the same


def test_a_few_stray_reliable_pixels_do_not_outweigh_the_prior():

    resid = np.zeros((60, 200, 2), np.float32)
    ok = np.zeros((60, 200), bool)
    resid[30, 40, 0], ok[30, 40] = -40.0, True  # one wrong flow that passed the check
    resid[:, 150:, 0], ok[:, 150:] = 3.0, True
    prior = np.full((60, 1, 2), 5.0, np.float32)
    plain = fill_unreliable(resid.copy(), ok, 12.0)
    given = fill_unreliable(resid.copy(), ok, 12.0, prior=prior)
    assert plain[30, 44, 0] < -30  # alone, the stray pixel's flow fills around it
    assert given[30, 44, 0] == 5.0


def test_the_projective_fit_ignores_an_object_and_matches_plain_weighted_least_squares():
    """The flow of a known projective motion with an object moving on its own over a fifth
    of the frame: the fit recovers the motion; its last round is the weighted least squares
    of the samples, solved here without the normal equations (``np.linalg.lstsq``)."""
    h, w = 90, 160
    gx, gy = pixel_grid(h, w)
    true = np.array([3.0, 0.5, -0.2, -1.0, 0.1, 0.3, 0.4, -0.6])
    rng = np.random.default_rng(8)
    flow = projective_flow(true, gx, gy, (h, w)) + rng.normal(0, 0.05, (h, w, 2))
    flow[20:65, 50:114, 0] += 6.0  # an object moving on its own, a fifth of the frame
    flow = flow.astype(np.float32)
    ok = np.ones((h, w), bool)
    ok[5, 5] = False
    coef = fit_projective(flow, ok, gx, gy, stride=4)
    assert np.abs(coef - true).max() < 0.2
    assert fit_projective(flow, np.zeros((h, w), bool), gx, gy) is None  # no samples
    # Reference: four rounds, each a plain weighted least-squares solve.
    sub = (slice(None, None, 4), slice(None, None, 4))
    use = ok[sub].ravel()
    xs = (gx[sub].ravel()[use] - 0.5 * w) / w
    ys = (gy[sub].ravel()[use] - 0.5 * h) / w
    uv = flow[sub].reshape(-1, 2)[use].astype(np.float64)
    one, zero = np.ones(xs.size), np.zeros(xs.size)
    a = np.concatenate([np.stack([one, xs, ys, zero, zero, zero, xs * xs, xs * ys], 1),
                        np.stack([zero, zero, zero, one, xs, ys, xs * ys, ys * ys], 1)])
    target = np.concatenate([uv[:, 0], uv[:, 1]])
    weight = np.ones(xs.size)
    for _ in range(4):
        sw = np.concatenate([weight, weight])[:, None]
        want = np.linalg.lstsq(a * sw, target * sw[:, 0], rcond=None)[0]
        r = np.hypot(*(a @ want - target).reshape(2, -1))
        weight = 1.0 / np.maximum(r / (1.5 * np.median(r) + 1e-3), 1.0)
    assert np.abs(coef - want).max() < 1e-6


def test_snap_to_camera_drops_the_flows_noise_and_keeps_an_object():
    """Rows bent by a vibration, a flow with 0.3 px of noise beside the camera's, and a
    square that moves 4 px on its own: the noise goes, the square keeps its motion."""
    rng = np.random.default_rng(3)
    h, w = 80, 120
    other = cv2.GaussianBlur(rng.uniform(0, 255, (h, w)).astype(np.float32), (0, 0), 1.5)
    gx, gy = pixel_grid(h, w)
    cam = np.zeros((h, w, 2), np.float32)
    cam[..., 0] = 2.0 * np.sin(2 * np.pi * gy / 40)  # each row shifted: not projective
    truth = cam.copy()
    truth[30:50, 50:70, 0] += 4.0  # the square's own motion
    cur = cv2.remap(other, gx + truth[..., 0], gy + truth[..., 1], cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_REPLICATE)
    flow = truth + rng.normal(0, 0.3, (h, w, 2)).astype(np.float32)
    resid = snap_to_camera(cur, other, flow, flow - cam)
    away = np.ones((h, w), bool)
    away[22:58, 42:78] = False  # beyond the patch's reach of the square
    assert np.abs(resid[away]).mean() < 0.1 * np.abs((flow - cam)[away]).mean()
    assert np.allclose(resid[34:46, 54:66], (flow - cam)[34:46, 54:66])
