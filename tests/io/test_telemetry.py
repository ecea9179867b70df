"""The gyro a camera wrote into its own file, read by telemetry-parser."""

import json

import numpy as np
import pytest

from unjello.io.sidecars import write_gyro
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
    assert err < 0.05 * unc  # measured: 0.00004x


@pytest.mark.slow
def test_a_gyro_that_does_not_fit_hands_the_clip_to_the_dense_method(tmp_path, scene):
    """The camera's own gyro saw almost no rotation (as on a gimbal) while the picture
    pans: the frames its calibration held go to the dense method, whose motion is then
    exactly what asking for the dense method gives; the JSON, the motion file and a
    warning say so. A log given with --gyro that does not fit is still an error."""
    src = tmp_path / "pan.mp4"
    make_clip(src, scene, n=32, fps=25, speed=6.0)
    t = np.arange(-1.0, 32 / 25 + 1.0, 1 / 400)
    rates = np.random.default_rng(3).normal(0.0, 2e-3, (t.size, 3))  # gimbal-still
    _write_gcsv(src.with_suffix(".gcsv"), t - t[0], rates)
    res = run("correct", src, "-o", tmp_path / "gyro.mp4", "--method", "gyro", "--json",
              "-q", "--motion-out", tmp_path / "gyro.json")
    assert res.returncode == 0, res.stderr
    summary = json.loads(res.stdout)
    assert summary["method"] == "dense" and summary["frames"] == 32
    gyro = summary["gyro"]
    assert gyro["used"] is False and gyro["explains"] < 0.3
    assert "the camera's own gyro" in gyro["source"] and "row motion" in gyro["why"]
    assert "warning: the camera's own gyro was not used" in res.stderr
    res = run("correct", src, "-o", tmp_path / "dense.mp4", "-q", "--motion-out",
              tmp_path / "dense.json")
    assert res.returncode == 0, res.stderr
    fell, dense = (json.loads((tmp_path / f).read_text()) for f in ("gyro.json", "dense.json"))
    assert fell["method"] == dense["method"] == "dense"
    assert [f["displacement"] for f in fell["frames"]] == \
        [f["displacement"] for f in dense["frames"]]
    write_gyro(tmp_path / "log.csv", t - t[0], rates)
    line = clean_failure(run("correct", src, "-o", tmp_path / "log.mp4", "--gyro",
                             tmp_path / "log.csv", "-q"))
    assert "does not explain" in line
    assert not (tmp_path / "log.mp4").exists()


@pytest.mark.slow
def test_gopro_files(shared_data, tmp_path):
    """The HERO5 Black on a Karma drone and the GoPro Max: both gyros are read. The Max
    stabilised its picture itself (HyperSmooth), so its gyro no longer describes it; the
    Karma's gimbal keeps the camera from rotating, so its gyro does not explain the
    picture's motion (the drone's travel does). Both are corrected by the dense method,
    and --json names the camera, the readout and its source, and what became of the gyro."""
    folder = shared_data / "sequences" / "gopro_gpmf"
    karma = embedded_gyro(folder / "karma.mp4")
    assert karma is not None and (karma.camera, karma.model) == ("GoPro", "HERO5 Black")
    assert karma.log.time.size > 4500 and 390 < karma.rate_hz < 405
    assert karma.stabilised == ""
    gmax = embedded_gyro(folder / "max-heromode.mp4")
    assert gmax is not None and gmax.model == "GoPro Max" and gmax.log.time.size > 2000
    assert gmax.stabilised == "HS HLevel"
    fast = ("--camera-only", "--flow-preset", "ultrafast", "--vibration", "off")
    for name, camera, why in (("karma.mp4", "GoPro HERO5 Black", "row motion"),
                              ("max-heromode.mp4", "GoPro Max", "stabilised the picture")):
        res = run("correct", folder / name, "-o", tmp_path / name, "--method", "gyro",
                  "--json", *fast)
        assert res.returncode == 0, res.stderr
        summary = json.loads(res.stdout)
        assert summary["method"] == "dense" and (tmp_path / name).exists()
        assert summary["sources"]["readout"] == f"camera database ({camera})"
        assert camera in summary["gyro"]["source"] and summary["gyro"]["used"] is False
        assert why in summary["gyro"]["why"] and summary["gyro"]["explains"] < 0.3
        assert "warning: the camera's own gyro was not used: " in res.stderr


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
