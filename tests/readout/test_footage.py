import numpy as np
import pytest

from unjello.errors import InputError
from unjello.io.frames import read_image
from unjello.readout.flicker import readout_from_flicker
from unjello.readout.footage import estimate_readout
from unjello.simulate import Motion, simulate
from unjello.timing import SensorTiming


def flicker_frame(rho, fps, freq, *, h=720, w=320, exposure=0.0002, noise=6.0, cover=1.0,
                  seed=0):
    """A frame of a light flickering at ``freq`` Hz seen by a sensor with readout ``rho``."""
    rng = np.random.default_rng(seed)
    t_row = rho / fps * np.arange(h) / h  # seconds
    # Square-wave light integrated over the exposure (box blur in time).
    sub = np.linspace(0, exposure, 16)[None, :]
    light = (np.sin(2 * np.pi * freq * (t_row[:, None] - sub)) > 0).mean(axis=1)
    scene = 80 + 60 * rng.random((h, w))
    img = scene * (0.3 + 0.7 * light[:, None])
    if cover < 1.0:  # the light only reaches part of the frame
        img[:, int(w * cover):] = scene[:, int(w * cover):] * 0.3
    return np.clip(img + rng.normal(0, noise, img.shape), 0, 255).astype(np.uint8)


@pytest.mark.parametrize("rho, fps, freq", [(0.5, 30, 1000), (0.9, 30, 1000),
                                            (0.3, 60, 1000), (1.0, 30, 120)])
def test_simulated_flicker(rho, fps, freq):
    img = flicker_frame(rho, fps, freq)
    r = readout_from_flicker(img, freq)
    assert r.ratio(fps) == pytest.approx(rho, rel=0.01)


def test_flicker_blur_and_partial_cover():
    img = flicker_frame(0.7, 30, 1000, exposure=0.0003, noise=12, cover=0.4)
    assert readout_from_flicker(img, 1000).ratio(30) == pytest.approx(0.7, rel=0.01)


def test_flicker_other_direction():
    img = flicker_frame(0.6, 30, 1000).T.copy()  # read left to right
    r = readout_from_flicker(img, 1000, direction="left-right")
    assert r.ratio(30) == pytest.approx(0.6, rel=0.01)


def test_no_bands():
    rng = np.random.default_rng(1)
    with pytest.raises(InputError):
        readout_from_flicker(rng.integers(0, 255, (200, 100)).astype(np.uint8), 1000)


def test_led_frame(shared_data):
    img = read_image(shared_data / "readout" / "led_1khz_nikon1j1_1080p30.png")
    r = readout_from_flicker(img, 1000.0)
    assert r.milliseconds == pytest.approx(15.730, rel=0.01)  # published 15.730 ms


@pytest.mark.parametrize("kind", ["shake", "stop"])
@pytest.mark.parametrize("rho", [0.5, 0.9])
def test_estimate_from_motion(scene, kind, rho):
    motion = Motion(kind, speed=7.0, stop_at=5.0)
    frames = [s.rolling for s in simulate(scene, motion, SensorTiming(rho), 12,
                                          size=(320, 240))]
    est = estimate_readout(frames)
    assert est.reliable and est.model == "smooth"
    assert est.readout == pytest.approx(rho, abs=0.05)


@pytest.mark.parametrize("rho", [0.3, 0.9])
def test_estimate_from_an_abrupt_start(scene, rho):
    # Still, then a diagonal pan within a quarter frame: measured 0.302 and 0.899 (0.366
    # and 0.946 before the acceleration penalty was made robust to the start).
    motion = Motion.steps([(0.0, 0.0), (8.0, 4.0)], [2.3])
    frames = [s.rolling for s in simulate(scene, motion, SensorTiming(rho), 12,
                                          size=(320, 240))]
    est = estimate_readout(frames)
    assert est.reliable and est.readout == pytest.approx(rho, abs=0.03)


@pytest.mark.parametrize("rho", [0.3, 0.7])
def test_estimate_from_vibration(scene, rho):
    # Drone jello (23, 31, 39 Hz at 30 fps): scored with the vibration model. Measured
    # 0.269 and 0.704; the smooth model found it unsure at every readout (biased long).
    frames = [s.rolling for s in simulate(scene, Motion("jello"), SensorTiming(rho), 12,
                                          size=(320, 240))]
    est = estimate_readout(frames)
    assert est.reliable and est.model == "vibration"
    assert est.readout == pytest.approx(rho, abs=0.05)


def test_uniform_motion_falls_back(scene):
    frames = [s.rolling for s in simulate(scene, Motion("diagonal", speed=6.0),
                                          SensorTiming(0.5), 8, size=(320, 240))]
    est = estimate_readout(frames, fallback=1.0)
    assert not est.reliable and est.readout == 1.0


def test_a_best_guess_outside_the_frame_interval_is_not_pooled():
    """Neither cue can tell: the motion's 0.66 +-0.06 and the lines' -0.52 +-0.14 (TUM RS-VI
    sequence 9, a deep room). A readout under 0 is impossible, not uncertain: the best
    guess is the motion's alone (it was pulled to 0.47)."""
    from unjello.readout.footage import ReadoutEstimate, _combine
    from unjello.readout.lines import LineCue

    empty = np.zeros(0)
    motion = ReadoutEstimate(1.0, 0.4, False, empty, empty, "rotation", "none", 0.0607, 0.6646)
    est = _combine(motion, LineCue(-0.52, 0.137, "tracked"), 1.0)
    assert not est.reliable and est.readout == 1.0
    assert est.best_guess == pytest.approx(0.6646) and est.uncertainty == pytest.approx(0.0607)
    both = _combine(motion, LineCue(0.55, 0.137, "tracked"), 1.0)  # inside: pooled
    assert 0.55 < both.best_guess < 0.6646
