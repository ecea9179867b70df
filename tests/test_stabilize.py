"""Stabilisation in the same warp: the smooth path, the reframe, one resampling."""

import json

import cv2
import numpy as np
import pytest

from unjello.config import CorrectionConfig
from unjello.errors import SettingsError
from unjello.exports.outputs import backward_maps
from unjello.io.frames import write_image
from unjello.pipeline import correct_frames
from unjello.simulate import Motion, simulate
from unjello.stabilize import (
    COHERENT,
    StabilizeConfig,
    Stabilizer,
    reference_step,
    smooth_path,
    step_coherence,
)
from unjello.timing import SensorTiming, pixel_grid
from unjello.trajectory import FrameMotion, Reframe, Trajectory
from unjello.warp.maps import reframe_maps
from unjello.warp.warper import apply_maps

from .runner import clean_failure, run

TIMING = SensorTiming(0.8)


@pytest.fixture(scope="module")
def shaky(scene):
    """40 frames of simulated hand shake, 320x240, readout 0.8."""
    return list(simulate(scene, Motion("shake"), TIMING, 40, size=(320, 240)))


@pytest.fixture(scope="module")
def stabilised(shaky):
    config = CorrectionConfig(stabilize=StabilizeConfig(True, 0.3, 0.1))
    return correct_frames([s.rolling for s in shaky], TIMING, config=config)


def _content_path(sims, traj):
    """Where the output shows the scene, per frame: the true path plus the shift."""
    tref = [TIMING.reference_time(240, s.motion.start) for s in sims]
    true = Motion("shake")(np.array(tref))
    return true, true + np.array([f.reframe.shift for f in traj.frames])


@pytest.mark.slow
def test_shake_is_taken_out(shaky, stabilised):
    # Measured: frame-to-frame motion 3.5 px RMS in, 0.3 out (0.09x).
    true, shown = _content_path(shaky, stabilised[1])
    before = np.sqrt((np.diff(true, axis=0) ** 2).sum(axis=1).mean())
    after = np.sqrt((np.diff(shown, axis=0) ** 2).sum(axis=1).mean())
    assert after < 0.15 * before


@pytest.mark.slow
def test_a_pan_is_kept_and_the_shift_stays_in_the_crop(scene):
    t = np.arange(-2.0, 40.0, 0.25)
    shake = Motion("shake")(t)
    pan = np.stack([5.0 * t, np.zeros_like(t)], axis=1) + shake
    motion = Motion("spline", knots=(tuple(t), tuple(pan[:, 0]), tuple(pan[:, 1])))
    sims = list(simulate(scene, motion, TIMING, 36, size=(320, 240)))
    config = CorrectionConfig(stabilize=StabilizeConfig(True, 0.3, 0.1))
    _, traj = correct_frames([s.rolling for s in sims], TIMING, config=config)
    shifts = np.array([f.reframe.shift for f in traj.frames])
    margin = 0.5 * np.array([320, 240]) * 0.1
    assert (np.abs(shifts) < margin).all()
    # The output moves with the pan: 5 px per frame, give or take the shake left.
    tref = np.array([TIMING.reference_time(240, s.motion.start) for s in sims])
    shown = motion(tref) + shifts
    speed = np.diff(shown, axis=0).mean(axis=0)
    assert speed[0] == pytest.approx(5.0, abs=0.3) and abs(speed[1]) < 0.3


@pytest.mark.slow
def test_one_warp_is_sharper_than_correcting_then_stabilising(shaky, stabilised):
    # The same reframes applied to the plain correction: a second resampling blurs.
    one, traj = stabilised
    plain, _ = correct_frames([s.rolling for s in shaky], TIMING)
    grid = pixel_grid(240, 320)

    def sharpness(img):
        grey = cv2.cvtColor(img, cv2.COLOR_RGB2GRAY).astype(np.float64)[40:200, 50:270]
        return np.abs(cv2.Laplacian(grey, cv2.CV_64F)).mean()

    ones, twos = [], []
    for k in range(0, 40, 4):
        maps = reframe_maps(grid, traj.frames[k].reframe, (240, 320))
        ones.append(sharpness(one[k]))
        twos.append(sharpness(apply_maps(plain[k], maps)))
    # Measured: 8.52 / 7.36, 7.93 / 7.39, 8.05 / 7.13 on three frames.
    assert np.mean(ones) > 1.05 * np.mean(twos)


def test_reframe_maps_shift_and_zoom():
    grid = pixel_grid(9, 11)
    mx, my = reframe_maps(grid, Reframe((0.0, 0.0), 2.0), (9, 11))
    # Zoom 2 about the centre (5, 4): pixel (0, 0) reads (2.5, 2).
    assert (mx[0, 0], my[0, 0]) == pytest.approx((2.5, 2.0))
    # The shift is in pixels of the frame: on a half-size grid it is half as many samples.
    half = pixel_grid(5, 6)
    hx, _ = reframe_maps(half, Reframe((4.0, 0.0), 1.0), (10, 12))
    assert np.allclose(hx - half[0], -2.0)


def test_look_ahead_is_bounded():
    stab = Stabilizer(StabilizeConfig(True, 0.3, "auto"), TIMING, (320, 240), 30.0)
    v = np.tile([2.0, 0.0], (240, 1))
    out = []
    for i in range(60):
        out += stab.push([FrameMotion(i, float(i), np.zeros((240, 2)), v)])
        assert i + 1 - len(out) <= stab.lookahead + 1
    out += stab.flush()
    assert [f.index for f in out] == list(range(60))
    # A steady pan needs no shift and no zoom.
    assert max(abs(s) for f in out for s in f.reframe.shift) < 1e-6
    assert max(f.reframe.zoom for f in out) == pytest.approx(1.0, abs=1e-3)


def test_a_frame_without_motion_keeps_the_last_step():
    v = np.tile([3.0, 0.0], (100, 1))
    frames = [FrameMotion(i, float(i), np.zeros((100, 2)), v) for i in range(3)]
    lost = FrameMotion(3, 3.0, np.zeros((100, 2)), np.zeros((100, 2)), ok=False)
    stab = Stabilizer(StabilizeConfig(True, 0.2, "none"), TIMING, (200, 100), 30.0)
    out = stab.push(frames + [lost, FrameMotion(4, 4.0, np.zeros((100, 2)), v)])
    out += stab.flush()
    assert max(abs(f.reframe.shift[0]) for f in out) < 1e-6


def test_reference_step_is_the_velocity_integral():
    v = np.tile([0.0, 0.0], (50, 1))
    v[:, 0] = np.linspace(0, 4, 50)  # accelerating through the frame
    a = FrameMotion(0, 0.0, np.zeros((50, 2)), v)
    b = FrameMotion(1, 1.0, np.zeros((50, 2)), v + 4.0 * np.array([1.0, 0.0]))
    step = reference_step(a, b, SensorTiming(1.0))
    # From t = 0.5 to 1.5 the velocity rises from 2 to 6 (4 per interval): 4 px.
    assert step[0] == pytest.approx(4.0, abs=0.1)


def test_smooth_path_turns_a_corner_without_lag():
    q = np.stack([8.0 * np.maximum(np.arange(80) - 40, 0), np.zeros(80)], axis=1)
    robust = np.abs(smooth_path(q, 1e4) - q).max()
    quadratic = np.abs(smooth_path(q, 1e4, rounds=0) - q).max()
    assert robust < 0.2 * quadratic


def test_motion_json_and_stmap_carry_the_reframe(stabilised, tmp_path):
    _, traj = stabilised
    path = tmp_path / "m.json"
    traj.save(path)
    doc = json.loads(path.read_text())
    assert "shift" in doc["frames"][5] and doc["frames"][5]["zoom"] == pytest.approx(1 / 0.9)
    back = Trajectory.load(path)
    assert back.frames[5].reframe.shift == pytest.approx(traj.frames[5].reframe.shift,
                                                         abs=1e-4)
    # The STMap's maps are the warp's: identity correction + reframe = reframe alone.
    fm = FrameMotion(0, 0.0, np.zeros((24, 2)), np.zeros((24, 2)),
                     reframe=Reframe((3.0, -2.0), 1.25))
    mx, my = backward_maps(fm, 32)
    ex, ey = reframe_maps(pixel_grid(24, 32), fm.reframe, (24, 32))
    assert np.allclose(mx, ex) and np.allclose(my, ey)


def test_settings():
    assert CorrectionConfig().with_options(stabilize=True, crop="0.1").stabilize.crop == 0.1
    assert CorrectionConfig.from_preset("handheld").stabilize.enabled
    for bad in ("big", "0.7", "-0.1"):
        with pytest.raises(SettingsError, match="crop"):
            CorrectionConfig().with_options(crop=bad)
    with pytest.raises(SettingsError, match="smoothness"):
        CorrectionConfig().with_options(smoothness="0")
    with pytest.raises(SettingsError, match="warp=remap"):
        CorrectionConfig().with_options(stabilize=True, warp="splat")


def test_cli(tmp_path, shaky):
    src = tmp_path / "in"
    src.mkdir()
    for i, s in enumerate(shaky[:12]):
        write_image(src / f"f{i:03d}.png", s.rolling)
    res = run("correct", src, "-o", tmp_path / "out", "--readout", "0.8", "--stabilize",
              "--crop", "0.1", "--motion-out", tmp_path / "m.json", "--json")
    assert res.returncode == 0, res.stderr
    said = json.loads(res.stdout)["stabilized"]
    assert said["zoom"] == pytest.approx([1 / 0.9, 1 / 0.9], abs=1e-3)
    assert "stabilised: camera path smoothed over 0.3 s" in res.stderr
    frames = json.loads((tmp_path / "m.json").read_text())["frames"]
    assert len(frames) == 12 and all("shift" in f for f in frames[1:])
    line = clean_failure(run("correct", src, "-o", tmp_path / "out2", "--stabilize",
                             "--crop", "lots"))
    assert "crop" in line


def test_plot_shows_the_camera_path_and_the_smoothed_one(stabilised, tmp_path):
    from unjello.exports.outputs import plot_trajectory
    from unjello.io.frames import read_image

    _, traj = stabilised
    plot_trajectory(traj, tmp_path / "p.png")
    plain = Trajectory(traj.timing, traj.size, method="dense",
                       frames=[FrameMotion(f.index, f.start, f.displacement, f.velocity)
                               for f in traj.frames])
    plot_trajectory(plain, tmp_path / "q.png")
    # A third panel (9 inches high instead of 6).
    assert read_image(tmp_path / "p.png").shape[0] > 1.4 * read_image(tmp_path / "q.png").shape[0]
    path = np.array([f.reframe.path for f in traj.frames])
    assert path.shape == (len(traj.frames), 3) and not path[0].any()


def _turned(scene, angles):
    """320x240 crops of ``scene`` turned by each angle (degrees) about its centre."""
    img = cv2.resize(scene, (440, 440))
    return [cv2.warpAffine(img, cv2.getRotationMatrix2D((220, 220), a, 1.0),
                           (440, 440))[100:340, 60:380] for a in angles]


def _tracked_roll(pictures):
    """RMS roll per frame (radians) between 320x240 pictures, as the stabiliser tracks it."""
    from unjello.stabilize import track, tracked_step, tracking_copy

    zero = np.zeros((240, 2))
    grey = [cv2.cvtColor(f, cv2.COLOR_RGB2GRAY).astype(np.float32) for f in pictures]
    steps = [tracked_step(track(tracking_copy(a), tracking_copy(b)),
                          FrameMotion(0, 0.0, zero, zero),
                          FrameMotion(1, 1.0, zero, zero), (159.5, 119.5))[2]
             for a, b in zip(grey[:-1], grey[1:], strict=True)]
    return float(np.sqrt(np.mean(np.square(steps))))


@pytest.mark.slow
def test_roll_is_taken_out(scene):
    # Frames turned by a 2 degree, 12-frame wobble and a 1 degree, 5-frame one (read
    # almost at once): measured 1.08 -> 0.32 degrees of roll per frame (RMS) at 480x360.
    angles = (2.0 * np.sin(2 * np.pi * np.arange(36) / 12)
              + 1.0 * np.sin(2 * np.pi * np.arange(36) / 5))
    frames = _turned(scene, angles)
    config = CorrectionConfig().with_options(stabilize=True, crop="0.1")
    out, traj = correct_frames(frames, SensorTiming(0.05), config=config)
    # The steps are measured as the frames were made.
    assert _tracked_roll(frames) == pytest.approx(
        np.sqrt(np.mean(np.radians(np.diff(angles)) ** 2)), rel=0.02)
    assert _tracked_roll(out) < 0.45 * _tracked_roll(frames)
    assert any(abs(f.reframe.angle) > 0.005 for f in traj.frames)


def test_the_gyro_method_stabilises_along_the_gyros_path(shaky, stabilised):
    """With the gyro method the path is the gyro's rotation at each frame's reference
    time, not points tracked in the picture. Measured on the 40 shaky frames, path less
    the truth (its mean taken out), px RMS x / y: gyro 0.004 / 0.002, tracked 0.02 / 0.05."""
    from unjello.gyrolog import GyroConfig, GyroLog
    from unjello.pipeline import Corrector
    from unjello.simulate import gyro_samples

    t, rates = gyro_samples(Motion("shake", fps=30.0), 1500.0, 40 / 30)
    config = CorrectionConfig(method="gyro", stabilize=StabilizeConfig(True, 0.3, 0.1),
                              gyro=GyroConfig(sync_frames=20))
    corr = Corrector(TIMING, config, fps=30.0, gyro_log=GyroLog(t, rates))
    fms = [fm for i, s in enumerate(shaky) for _, fm in corr.push([s.rolling], float(i))]
    fms += [fm for _, fm in corr.flush()]
    assert corr.method == "gyro" and len(fms) == 40
    true, _ = _content_path(shaky, stabilised[1])
    errors = {}
    for name, frames in (("gyro", fms), ("tracked", stabilised[1].frames)):
        err = np.array([f.reframe.path[:2] for f in frames]) - (true - true[0])
        errors[name] = np.sqrt(np.mean((err - err.mean(axis=0)) ** 2, axis=0))
    assert (errors["gyro"] < 0.02).all(), errors
    assert errors["gyro"].max() < errors["tracked"].max() / 2, errors


def test_step_coherence_tells_a_real_turn_from_a_trackers_noise():
    # A tracker's independent error on each frame pair: steps of white noise score
    # 0 +- 1 (the units of step_coherence); a roll wobble of 1-3 Hz sampled at 30 fps,
    # as small as the noise, scores far above COHERENT.
    rng = np.random.default_rng(3)
    noise = [step_coherence(np.cumsum(rng.normal(0, 1e-3, 55))) for _ in range(400)]
    assert abs(np.mean(noise)) < 0.2
    assert 0.7 < np.std(noise) < 1.3
    assert np.mean(np.array(noise) > COHERENT) < 0.05
    t = np.arange(55) / 30.0
    for hz in (1.0, 2.0, 3.0):
        wobble = 1e-3 * np.sin(2 * np.pi * hz * t + hz)
        assert step_coherence(wobble + np.cumsum(rng.normal(0, 1e-4, 55))) > 2 * COHERENT


@pytest.mark.slow
def test_a_small_roll_that_steps_coherently_is_taken_out(scene):
    # A 0.06 degree, 12-frame roll wobble: under the floor (ROLL_FLOOR) below which a
    # tracked roll is mostly noise, but its steps follow one another (step_coherence), so
    # it is smoothed. Measured at 320x240: 0.022 -> 0.003 degrees per frame (RMS); with
    # the floor alone 0.022 -> 0.021, no frame turned.
    frames = _turned(scene, 0.06 * np.sin(2 * np.pi * np.arange(36) / 12))
    config = CorrectionConfig().with_options(stabilize=True, crop="0.1")
    out, traj = correct_frames(frames, SensorTiming(0.05), config=config)
    assert _tracked_roll(out) < 0.4 * _tracked_roll(frames)
    assert any(abs(f.reframe.angle) > 2e-4 for f in traj.frames)
