"""The gyro a camera wrote into its own file, read by telemetry-parser."""

import json

import numpy as np
import pytest

from unjello.io.telemetry import embedded_gyro
from unjello.simulate import Motion, gyro_samples, simulate
from unjello.timing import SensorTiming

from ..clips import make_clip, motion_file_error
from ..runner import clean_failure, run

pytest.importorskip("telemetry_parser", reason="telemetry-parser is not installed")

GSCALE = 1e-5  # rad/s per unit of the log


def _write_gcsv(path, t, rates, orientation="XYZ", readout_ms=None):
    """A Gyroflow IMU log (.gcsv) beside a video: telemetry-parser reads it as the
    camera's own gyro, as it reads a GoPro's GPMF or a Sony's rtmd."""
    lines = ["GYROFLOW IMU LOG", "version,1.3", "id,unjello_test", f"orientation,{orientation}",
             "vendor,simcam", "tscale,0.001", f"gscale,{GSCALE}", "t,gx,gy,gz"]
    if readout_ms is not None:
        lines.insert(5, f"frame_readout_time,{readout_ms}")
    lines += [f"{1000 * ti:.3f},{a / GSCALE:.0f},{b / GSCALE:.0f},{c / GSCALE:.0f}"
              for ti, (a, b, c) in zip(t, rates, strict=True)]
    path.write_text("\n".join(lines) + "\n")


def test_a_plain_video_has_no_gyro(tmp_path, scene):
    src = tmp_path / "plain.mp4"
    make_clip(src, scene, n=4)
    assert embedded_gyro(src) is None
    assert embedded_gyro(tmp_path / "missing.mp4") is None


def test_the_samples_come_back_in_seconds_and_rad_per_second(tmp_path, scene):
    src = tmp_path / "cam.mp4"
    make_clip(src, scene, n=4)
    t, rates = gyro_samples(Motion("shake", fps=25.0), 1500.0, 2.0)
    t = t - t[0]  # the log starts with the video
    _write_gcsv(src.with_suffix(".gcsv"), t, rates)
    found = embedded_gyro(src)
    assert found is not None and found.stabilised == ""
    assert found.log.time.size == t.size
    assert np.allclose(found.log.time, t, atol=1e-6)
    assert np.allclose(found.log.rate, rates, atol=GSCALE)
    assert "400 Hz" in found.describe() and "telemetry-parser" in found.describe()


def test_the_gyro_method_uses_the_cameras_own_gyro(tmp_path, scene):
    """No --gyro and no NAME.gyro.csv: the file's own gyro (here Gyroflow's .gcsv beside
    it, through the same reader as a GoPro's) is found, said, calibrated and used."""
    src = tmp_path / "pan.mp4"
    make_clip(src, scene, n=32, fps=25, speed=6.0)
    t, rates = gyro_samples(Motion("pan", fps=25.0, speed=6.0), 1500.0, 32 / 25)
    _write_gcsv(src.with_suffix(".gcsv"), t - t[0], rates)
    res = run("correct", src, "-o", tmp_path / "out.mp4", "--method", "gyro", "--json",
              "--motion-out", tmp_path / "m.json")
    assert res.returncode == 0, res.stderr
    summary = json.loads(res.stdout)
    assert "the camera's own gyro" in summary["sources"]["gyro"]
    assert any(m.startswith("gyro: the camera's own gyro") for m in summary["messages"])
    sim = list(simulate(scene, Motion("pan", speed=6.0), SensorTiming(1.0), 32, size=(192, 144)))
    err, unc = motion_file_error(tmp_path / "m.json", sim)
    assert err < 0.1 * unc


def test_gopro_files(shared_data, tmp_path):
    """The HERO5 Black on a Karma drone and the GoPro Max: both gyros are read. The Max
    stabilised its picture itself (HyperSmooth), so its gyro no longer describes it; the
    Karma's gimbal keeps the camera from rotating, so its gyro explains a fifth of the
    picture's motion (the drone's travel is the rest). Each is one clear line."""
    folder = shared_data / "sequences" / "gopro_gpmf"
    karma = embedded_gyro(folder / "karma.mp4")
    assert karma is not None and (karma.camera, karma.model) == ("GoPro", "HERO5 Black")
    assert karma.log.time.size > 4500 and 390 < karma.rate_hz < 405
    assert karma.stabilised == ""
    gmax = embedded_gyro(folder / "max-heromode.mp4")
    assert gmax is not None and gmax.model == "GoPro Max" and gmax.log.time.size > 2000
    assert gmax.stabilised == "HS HLevel"
    line = clean_failure(run("correct", folder / "max-heromode.mp4", "-o",
                             tmp_path / "max.mp4", "--method", "gyro"))
    assert "stabilised the picture itself" in line and "GoPro Max" in line
    line = clean_failure(run("correct", folder / "karma.mp4", "-o", tmp_path / "karma.mp4",
                             "--method", "gyro", "-q"))
    assert "does not explain" in line and "gimbal" in line
    assert not (tmp_path / "karma.mp4").exists() and not (tmp_path / "max.mp4").exists()


def test_a_parser_panic_is_no_traceback():
    """telemetry-parser's Rust panics reach Python as a BaseException (pyo3's
    PanicException); reading a file must survive them, and let an interrupt through."""
    from unjello.io.telemetry import vendor_call

    class Panic(BaseException):  # what pyo3 raises
        pass

    def boom():
        raise Panic("called `Option::unwrap()` on a `None` value")

    assert vendor_call(boom, "fallback") == "fallback"
    assert vendor_call(lambda: 3, None) == 3

    def interrupted():
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        vendor_call(interrupted, None)


def test_the_readout_the_camera_states(tmp_path, scene):
    """A readout in the camera's metadata (here the .gcsv header's frame_readout_time, as
    telemetry-parser decodes it) is used without --readout, and said."""
    src = tmp_path / "cam.mp4"
    make_clip(src, scene, n=3)
    t, rates = gyro_samples(Motion("pan", fps=30.0), 1500.0, 0.2)
    _write_gcsv(src.with_suffix(".gcsv"), t - t[0], rates, readout_ms=15.0)
    res = run("correct", src, "-o", tmp_path / "out.mp4", "--json")
    assert res.returncode == 0, res.stderr
    summary = json.loads(res.stdout)
    assert summary["sources"]["readout"].startswith("camera metadata")
    assert summary["readout"] == pytest.approx(0.45)
