"""The gyro method: per-scanline homographies, calibration from the footage."""

import numpy as np
import pytest

from unjello.errors import InputError, SettingsError
from unjello.gyrolog import GyroConfig, GyroLog, axes_matrix
from unjello.metrics import displacement_error
from unjello.motion.gyro.method import GyroCalibration, GyroMethod, gyro_field
from unjello.simulate import Motion, gyro_samples, simulate
from unjello.timing import SensorTiming


def test_axes_matrix():
    assert np.array_equal(axes_matrix("XYZ"), np.eye(3))
    m = axes_matrix("yZx")  # camera x = -gyro y, camera y = gyro z, camera z = -gyro x
    assert np.array_equal(m @ np.array([1.0, 2.0, 3.0]), [-2.0, 3.0, -1.0])
    with pytest.raises(SettingsError, match="three letters"):
        axes_matrix("XXY")
    with pytest.raises(SettingsError, match="focal length must be positive"):
        GyroConfig(focal=-3.0)


def test_roll_is_a_rotation_of_each_row_about_the_centre():
    h, w, roll = 120, 160, 0.3  # rad/s about the camera's z axis, 30 fps
    t = np.linspace(-1, 2, 3001)
    log = GyroLog(t, np.tile([0.0, 0.0, roll], (t.size, 1)))
    cal = GyroCalibration(np.eye(3), offset=0.0, focal=200.0)
    timing = SensorTiming(1.0)
    field, disp, _, around = gyro_field(log, cal, timing, 0.0, 1 / 30, (h, w), step=1)
    c = np.array([(w - 1) / 2, (h - 1) / 2])
    for y in (0, 30, 90, 119):
        angle = roll * (timing.reference_time(h) - y / h) / 30  # reference minus row time
        rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
        s = np.stack([np.arange(w, dtype=float), np.full(w, float(y))], axis=-1)
        p = (s - c) @ rot.T + c
        assert np.allclose(field[y], s - p, atol=1e-3)
    assert np.abs(disp[60]).max() < 0.05  # the middle row is the reference
    # One frame later every pixel has turned by the roll over a frame interval.
    (k, later), = [n for n in around if n[0] == 1]
    angle = roll / 30
    rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    s = np.stack(np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float)), axis=-1)
    assert np.allclose(later, (s - c) @ rot.T + c - s, atol=1e-3)


def _shake_clip(n=40, size=(320, 240), readout=0.9):
    mot = Motion("shake", fps=30.0)
    timing = SensorTiming(readout)
    sim = list(simulate(__import__("skimage.data").data.astronaut(), mot, timing, n, size=size))
    return mot, timing, sim


@pytest.fixture(scope="module")
def shake():
    return _shake_clip()


def _run(method, sim):
    out = []
    for i, s in enumerate(sim):
        out += method.push(s.rolling.mean(axis=-1).astype(np.float32), float(i))
    return out + method.flush()


@pytest.mark.slow
def test_calibration_finds_offset_axes_focal_and_corrects_shake(shake):
    mot, timing, sim = shake
    w = sim[0].rolling.shape[1]
    focal, mount = 8.0 * w, axes_matrix("yZx")  # a long lens: rotation ~ translation
    t, rates = gyro_samples(mot, focal, len(sim) / 30, axes=mount, start=12.345,
                            noise=0.002)
    method = GyroMethod(timing, GyroLog(t, rates), GyroConfig(), fps=30.0)
    frames = _run(method, sim)
    cal = method.calibration
    assert abs(cal.offset - 12.345) < 0.002
    assert abs(cal.focal / focal - 1) < 0.03
    assert np.array_equal(cal.axes[:2], mount[:2])  # roll's sign: no roll in this clip
    assert cal.agreement > 0.95
    unc = np.mean([displacement_error(None, s.motion) for s in sim])
    err = np.mean([displacement_error(f, s.motion) for f, s in zip(frames, sim, strict=True)])
    # Measured: 0.753 px -> 0.024 px (0.031x).
    assert err < 0.1 * unc
    assert frames[0].note.startswith(cal.describe())  # the calibration, said once


def test_a_known_calibration_streams_frame_by_frame(shake):
    mot, timing, sim = shake
    focal = 8.0 * sim[0].rolling.shape[1]
    t, rates = gyro_samples(mot, focal, len(sim) / 30)
    method = GyroMethod(timing, GyroLog(t, rates),
                        GyroConfig(axes="XYZ", offset=0.0, focal=focal), fps=30.0)
    for i, s in enumerate(sim[:3]):
        got = method.push(s.rolling.mean(axis=-1), float(i))
        assert [f.index for f in got] == [i]


@pytest.mark.slow
def test_a_log_of_another_clip_is_refused(shake):
    _, timing, sim = shake
    t = np.arange(0, 5, 1 / 400)
    rates = np.random.default_rng(1).normal(0, 0.05, (t.size, 3))
    method = GyroMethod(timing, GyroLog(t, rates), GyroConfig(sync_frames=30), fps=30.0)
    with pytest.raises(InputError, match="does not explain"):
        _run(method, sim[:30])


@pytest.mark.slow
def test_real_phone_clip_calibrates_to_its_published_intrinsics(shared_data):
    """The hand-held phone clip: focal near the published K (573.9 px), offset near the
    frame timestamps (the middle row's time within a frame interval of frame 99's stamp).
    """
    from unjello.io.frames import list_frames, read_image
    from unjello.io.sidecars import read_gyro

    root = shared_data / "sequences" / "phone_gyro"
    files = list_frames(root / "reshape")[:45]
    log = read_gyro(root / "gyro.txt")
    timing = SensorTiming(1.0)
    method = GyroMethod(timing, log, GyroConfig(sync_frames=45), fps=30.0)
    for i, f in enumerate(files):
        method.push(read_image(f).mean(axis=-1).astype(np.float32), float(i))
    method.flush()
    cal = method.calibration
    stamp = np.loadtxt(root / "framestamp.txt")[99]
    assert abs(cal.focal / 573.85 - 1) < 0.06
    assert abs(cal.offset + 0.5 / 30 - stamp) < 1 / 30


@pytest.mark.parametrize("frame", [np.full((120, 160), 128.0, np.float32), None])
def test_footage_without_texture_or_motion_says_what_to_give(frame, scene):
    """A flat picture, or a camera on a tripod: nothing to calibrate against, one clear error."""
    img = frame if frame is not None else scene[:120, :160].mean(axis=-1).astype(np.float32)
    t = np.arange(0, 3, 1 / 400)
    log = GyroLog(t, np.random.default_rng(0).normal(0, 0.05, (t.size, 3)))
    method = GyroMethod(SensorTiming(1.0), log, GyroConfig(sync_frames=10), fps=30.0)
    with pytest.raises(InputError, match="give gyro_offset="):
        for i in range(10):
            method.push(img, float(i))
