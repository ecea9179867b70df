import numpy as np
import pytest
from skimage import data

from unjello.lens import Lens
from unjello.readout import rotation
from unjello.readout.footage import (
    ROTATION_EXPLAINS,
    estimate_clips,
    estimate_readout,
    readout_preset,
)
from unjello.simulate import Motion, simulate, simulate_rotation
from unjello.timing import SensorTiming


def _hand_rates(seed: int):
    """A hand-held camera's rates (rad/s) about x, y, z: three sinusoids each, 0.8-4 Hz."""
    rng = np.random.default_rng(seed)
    f, ph = rng.uniform(0.8, 4.0, (3, 3)), rng.uniform(0, 2 * np.pi, (3, 3))
    a = rng.uniform(0.6, 1.2, (3, 3))

    def rate(t):
        t = np.asarray(t)[..., None, None]
        return (a * np.sin(2 * np.pi * f * t + ph)).sum(-1) * np.array([1.0, 1.0, 0.4])
    return rate


def _world():
    img = data.astronaut()
    return np.concatenate([np.concatenate([img, img[:, ::-1]], 1),
                           np.concatenate([img[::-1], img[::-1, ::-1]], 1)], 0)


def _reference_cost(t_a, t_b, turn, flow, weight, focal):
    """The window's fit written plainly: a dense matrix, channel-major, no reweighting."""
    step = 1.0 / rotation.KNOTS
    t0 = min(t_a.min(), t_b.min()) - step
    n = int(np.ceil((max(t_a.max(), t_b.max()) + step - t0) / step)) + 2
    m = t_a.size

    def sample(t):
        u = (t - t0) / step
        i = np.floor(u).astype(int)
        s = np.zeros((m, n))
        s[np.arange(m), i] = 1 - (u - i)
        s[np.arange(m), i + 1] = u - i
        return s
    diff = sample(t_b) - sample(t_a)                                  # phi(t_b) - phi(t_a)
    a = np.concatenate([np.concatenate([turn[:, ax, ch, None] * diff for ch in range(3)], 1)
                        for ax in range(2)])
    b = np.concatenate([flow[:, 0], flow[:, 1]])
    w = np.concatenate([weight, weight])
    d2 = np.diff(np.eye(n), 2, axis=0)
    pen = np.kron(np.eye(3), d2.T @ d2) * (rotation.SMOOTHNESS * weight.sum() * step
                                          * focal ** 2)
    x = np.linalg.solve(a.T @ (w[:, None] * a) + pen, a.T @ (w * b))
    r = a @ x - b
    return float(np.sum(w * r * r) + x @ pen @ x), float(np.sum(w * b * b))


def test_window_fit_matches_its_dense_reference(monkeypatch):
    """The banded, knot-major assembly gives the plain dense least squares' cost."""
    monkeypatch.setattr(rotation, "ROBUST", 0)
    rng = np.random.default_rng(3)
    m = 300
    y = rng.uniform(0, 1, m)
    k = rng.integers(1, 4, m).astype(float)
    t_a, t_b = k + 0.7 * y, k - 1 + 0.7 * np.clip(y + rng.normal(0, 0.02, m), 0, 1)
    turn = rng.normal(0, 300, (m, 2, 3))
    flow = rng.normal(0, 3, (m, 2))
    weight = rng.uniform(0.3, 1, m)
    got = rotation._window_cost(t_a, t_b, turn, flow, weight, 300.0)
    assert got == pytest.approx(_reference_cost(t_a, t_b, turn, flow, weight, 300.0), rel=1e-6)


@pytest.mark.parametrize("rho, distortion", [(0.35, None), (0.8, (-0.02, 0.01, 0.0, 0.0))])
def test_a_turning_camera_gives_its_readout_and_lens(rho, distortion):
    """A camera turning about three axes through a pinhole (f 280 px) or a fisheye (f 220):
    the translation model read these 0.1-0.35 long (``benchmarks/readout.py --rotation``);
    the rotation model is within 0.05 and finds the lens.
    """
    focal = 280.0 if distortion is None else 220.0
    sim, _ = simulate_rotation(_world(), _hand_rates(1), SensorTiming(rho), 14,
                               size=(400, 320), focal=focal, distortion=distortion)
    est = estimate_readout([f.rolling for f in sim], lines=False)
    assert est.model == "rotation" and est.reliable
    assert est.readout == pytest.approx(rho, abs=0.05)
    assert abs(est.readout - rho) <= 2.5 * est.uncertainty
    # The lens sees each pixel along nearly the true ray (a fisheye with k1 near 1/3 is
    # all but a pinhole): within 5 degrees of the corner's 46, its focal length within 10 %.
    true = Lens(focal, distortion)
    pixels = np.stack([np.linspace(200, 399, 9), np.linspace(160, 319, 9)], axis=1)
    angle = [np.degrees(np.arctan(np.hypot(*lens.undistort(pixels, (320, 400)).T)))
             for lens in (true, est.lens)]
    assert np.abs(angle[0] - angle[1]).max() < 5.0
    assert est.lens.focal == pytest.approx(focal, rel=0.1)
    preset = readout_preset(est, "top-bottom", None)
    assert preset["focal"] == pytest.approx(est.lens.focal, abs=0.1)
    assert ("distortion" in preset) == (est.lens.k is not None)


def test_a_translating_scene_keeps_the_translation_model(scene):
    """Hand shake of a flat, far picture: no lens explains it better than the longest focal
    length, and the translation model's estimate stands."""
    frames = [s.rolling for s in simulate(scene, Motion("shake"), SensorTiming(0.7), 12,
                                          size=(320, 240))]
    est = estimate_readout(frames, lines=False)
    assert est.model == "smooth" and est.lens is None
    assert est.readout == pytest.approx(0.7, abs=0.03)


def test_given_lens_is_used():
    sim, _ = simulate_rotation(_world(), _hand_rates(2), SensorTiming(0.6), 12,
                               size=(400, 320), focal=280.0)
    est = estimate_readout([f.rolling for f in sim], lines=False, lens=Lens(280.0))
    assert est.model == "rotation" and est.lens == Lens(280.0)
    assert est.readout == pytest.approx(0.6, abs=0.05)


@pytest.mark.slow
def test_tum_halves_each_give_the_published_readout_and_pool(shared_data, tmp_path):
    """TUM RS-VI sequence 4 (1280x1024, 20 fps, hand-held): its authors' line delay makes
    the readout 0.60 of the frame interval. Each half of the 50 frames, on its own, is
    within 0.05 and reliable, its uncertainty covering the truth; pooled, within 0.03."""
    files = sorted((shared_data / "sequences" / "tum_rsvi_seq4").glob("*.png"))
    halves = [tmp_path / "a", tmp_path / "b"]
    for half, part in zip(halves, (files[:25], files[25:]), strict=True):
        half.mkdir()
        for f in part:
            (half / f.name).symlink_to(f)
    rows, pooled = estimate_clips(halves)
    for _, _, est in rows:
        assert est.reliable and est.model == "rotation"
        assert est.readout == pytest.approx(0.60, abs=0.05)
        assert abs(est.readout - 0.60) <= 2.0 * est.uncertainty
    assert pooled.reliable and pooled.readout == pytest.approx(0.60, abs=0.03)


@pytest.mark.slow
def test_phone_in_a_car_is_not_confidently_wrong(shared_data):
    """The phone in a moving car: its travel and the traffic are not a turn, the rotation
    model leaves 31 % of the motion unexplained and its windows scatter: unknown, with a
    best guess inside (0, 1] and an uncertainty that says how little it knows."""
    from unjello.io.frames import list_frames, read_image

    files = list_frames(shared_data / "sequences" / "phone_gyro" / "reshape")[:60]
    est = estimate_readout([read_image(f) for f in files])
    assert not est.reliable
    assert 0.0 < est.best_guess <= 1.0
    assert est.uncertainty >= 0.1
    assert est.model == "rotation" and est.explained < ROTATION_EXPLAINS


@pytest.mark.parametrize("model, reliable", [("rotation", True), ("smooth", False)])
def test_pooling_trusts_a_turning_cameras_estimates_to_their_own_bound(model, reliable):
    """TUM's frames 10-29 alone (0.62 +-0.056, unknown) and 30-50 (0.62 +-0.038) pool to
    +-0.031: within the rotation model's 0.05, not within the lines' 0.025."""
    from unjello.readout.footage import ReadoutEstimate, pool_estimates

    empty = np.zeros(0)
    clips = [ReadoutEstimate(1.0, 0.4, False, empty, empty, model, "none", 0.056, 0.619),
             ReadoutEstimate(0.617, 0.6, True, empty, empty, model, "motion", 0.038, 0.617)]
    pooled = pool_estimates(clips)
    assert pooled.reliable == reliable and pooled.model == model
    assert pooled.best_guess == pytest.approx(0.618, abs=0.001)
    assert pooled.uncertainty == pytest.approx(0.031, abs=0.001)


def test_a_fitted_lens_widens_the_readouts_uncertainty(monkeypatch):
    """A readout that moves 0.5 a unit of log focal length: the lens's share of its
    uncertainty is half its change over f / 1.1 .. f x 1.1 (a fitted focal length is known
    no better: on TUM RS-VI sequence 9 it came 8 % long, and the readout 0.06 high)."""
    candidates = np.round(np.arange(0.3, 1.0001, 0.05), 4)

    def fake(pairs, times, lens, size, readouts, every=1):
        rho = 0.6 + 0.5 * np.log(lens.focal / 500.0)
        return np.tile((readouts - rho) ** 2, (4, 1)), None
    monkeypatch.setattr(rotation, "rotation_costs", fake)
    sigma = rotation._lens_sigma([], np.zeros(0), (100, 100), Lens(500.0), candidates, 0.6)
    assert sigma == pytest.approx(0.5 * np.log(rotation.LENS_STEP), rel=0.02)
