"""The motion as a Gyroflow project: rates that Gyroflow's rule turns back into the motion."""

import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from unjello.config import CorrectionConfig
from unjello.errors import OutputError, SettingsError
from unjello.exports.gyroflow import (
    ORIENTATION,
    ProjectLens,
    camera_rates,
    export_project,
    gcsv_text,
    gyroflow_displacement,
    log_rates,
)
from unjello.gyrolog import GyroConfig
from unjello.io.gcsv import read_gcsv, stated_calibration
from unjello.metrics import displacement_error
from unjello.pipeline import correct_frames
from unjello.simulate import Motion, simulate
from unjello.timing import SensorTiming, coded_axes, to_top_bottom
from unjello.trajectory import FrameMotion

telemetry_parser = pytest.importorskip("telemetry_parser", reason="telemetry-parser is "
                                       "a default dependency on 3.11-3.12 only")

SIZE, FOCAL, FPS, N = (256, 192), 300.0, 30.0, 16


@pytest.fixture(scope="module", params=["pan", "shake", "jello"])
def exported(request, scene, tmp_path_factory):
    """A simulated clip corrected (camera only), exported, and read back by telemetry-parser."""
    timing = SensorTiming(0.9)
    sim = list(simulate(scene, Motion(request.param, fps=FPS), timing, N, size=SIZE))
    frames = [s.rolling for s in sim]
    _, traj = correct_frames(frames, timing,
                             config=CorrectionConfig().with_options(camera_only=True))
    work = tmp_path_factory.mktemp(request.param)
    (gcsv, proj), said = export_project(traj, work / "clip.gyroflow", video=work / "clip.mp4",
                                        fps=FPS, lens=ProjectLens(FOCAL), frames=N)
    imu = telemetry_parser.Parser(str(gcsv)).normalized_imu()
    read = (np.array([s["timestamp_ms"] for s in imu]), np.array([s["gyro"] for s in imu]))
    return request.param, timing, sim, frames, traj, gcsv, proj, read, said


def test_gyroflows_rule_applied_to_the_exported_rates_gives_back_the_motion(exported):
    """Read back by telemetry-parser and turned row by row as Gyroflow does under "No
    smoothing", the rates give the dense method's per-scanline camera motion within 0.05 px
    (mean; measured 0.003-0.012), and correct as well against the truth (within 1.2x, or
    0.02 px: Gyroflow's middle row is h / 2, unjello's (h - 1) / 2)."""
    case, timing, sim, _, traj, _, proj, (t_ms, gyro), _ = exported
    offset = json.loads(proj.read_text())["offsets"]["0"]
    rule = gyroflow_displacement(t_ms, gyro, offset_ms=offset, fps=FPS,
                                 readout_ms=timing.readout * 1000 / FPS,
                                 size=(SIZE[1], SIZE[0]), focal=FOCAL, frames=np.arange(N))
    own = np.stack([f.displacement for f in traj.frames])
    assert np.abs(own).mean() > 0.3  # there is motion to carry
    assert np.abs(rule - own).mean() < 0.05
    e_own = np.mean([displacement_error(f, s.motion) for f, s in zip(traj.frames, sim,
                                                                     strict=True)])
    e_rule = np.mean([displacement_error(FrameMotion(f.index, f.start, d, f.velocity),
                                         s.motion)
                      for f, d, s in zip(traj.frames, rule, sim, strict=True)])
    assert e_rule < max(1.2 * e_own, e_own + 0.02), case


def test_the_round_trip_through_the_gyro_method_reproduces_the_correction(exported):
    """``--method gyro --gyro clip.gcsv``: the log states its axes, clock and lens, and the
    gyro method's per-scanline motion is the camera-only one within 0.05 px (mean)."""
    _, timing, _, frames, traj, gcsv, _, _, _ = exported
    log, header = read_gcsv(gcsv)
    stated = stated_calibration(header, timing.direction)
    assert stated == {"axes": "XYZ", "offset": 0.0, "focal": pytest.approx(FOCAL)}
    config = CorrectionConfig(method="gyro", gyro=GyroConfig(path=str(gcsv), **stated))
    _, back = correct_frames(frames, timing, config=config, fps=FPS)
    own = np.stack([f.displacement for f in traj.frames])
    trip = np.stack([f.displacement for f in back.frames])
    assert all(f.ok for f in back.frames)
    assert np.abs(trip - own).mean() < 0.05


def test_the_project_names_what_gyroflow_reads(exported):
    """The .gyroflow file, field by field as Gyroflow's importer reads them (lib.rs)."""
    *_, gcsv, proj, _, said = exported
    doc = json.loads(proj.read_text())
    assert doc["version"] == 4 and doc["title"] == "Gyroflow data file"
    assert doc["videofile"].endswith("clip.mp4")
    assert doc["gyro_source"]["filepath"] == str(gcsv.resolve())
    assert doc["gyro_source"]["imu_orientation"] == ORIENTATION
    assert doc["gyro_source"]["integration_method"] == 3
    stab = doc["stabilization"]
    assert stab["method"] == "No smoothing" and stab["adaptive_zoom_window"] == 0.0
    assert stab["frame_readout_time"] == pytest.approx(0.9 * 1000 / FPS)
    assert stab["frame_readout_direction"] == "TopToBottom"
    assert doc["offsets"] == {"0": pytest.approx(-0.45 * 1000 / FPS)}
    lens = doc["calibration_data"]
    assert lens["distortion_model"] == "opencv_standard"
    assert lens["fisheye_params"]["camera_matrix"][0][0] == pytest.approx(FOCAL)
    assert lens["fisheye_params"]["distortion_coeffs"] == [0.0] * 5
    assert lens["calib_dimension"] == {"w": SIZE[0], "h": SIZE[1]}
    assert doc["video_info"]["num_frames"] == N and doc["video_info"]["fps"] == FPS
    head = gcsv.read_bytes()[:500].decode()
    assert head.startswith("GYROFLOW IMU LOG\n")
    assert "frame_readout_time,30.0000" in head and "frame_readout_direction," in head
    assert f"wrote {proj}" in said and "guessed" not in said


def test_rates_are_sampled_many_times_a_readout(exported):
    """At least 32 samples a readout, evenly, from the first frame's first scanline to the
    end of the last frame's interval, in telemetry-parser's reading as written."""
    _, timing, _, _, traj, gcsv, _, (t_ms, _), _ = exported
    step = np.diff(t_ms)
    assert step.max() - step.min() < 1e-3
    assert timing.readout * 1000 / FPS / step.mean() >= 32
    assert t_ms[0] == 0.0 and t_ms[-1] >= N * 1000 / FPS - step.mean()
    log, _ = read_gcsv(gcsv)
    assert log.time.size == t_ms.size


def test_a_camera_turning_about_each_axis_comes_out_on_that_axis():
    """A frame whose rows are displaced as a steady yaw (x) or pitch (y) of the camera
    would: the rates are on the camera's y or x axis, of the size f * rate = velocity."""
    timing, h, w = SensorTiming(1.0), 120, 160
    for axis, vel in ((1, np.array([6.0, 0.0])), (0, np.array([0.0, 6.0]))):
        frames = []
        for n in range(4):
            rows = np.arange(h)
            t = timing.row_times(h, n) - timing.reference_time(h, n)
            disp = t[:, None] * vel[None]
            frames.append(FrameMotion(n, float(n), disp, np.tile(vel, (h, 1))))
        from unjello.trajectory import Trajectory

        traj = Trajectory(timing, (w, h), frames)
        _, rate = camera_rates(traj, ProjectLens(400.0), FPS)
        mid = rate[rate.shape[0] // 3: 2 * rate.shape[0] // 3]
        expect = (vel[0] if axis == 1 else -vel[1]) / 400.0 * FPS  # rad/s
        assert np.median(mid[:, axis]) == pytest.approx(expect, rel=0.03)
        assert np.abs(np.median(mid[:, 1 - axis])) < 0.02 * abs(expect)
        del rows


def test_rates_about_the_coded_frames_axes_follow_the_turn_to_top_bottom(scene):
    """A pan read left to right: the frame the core sees is the coded one transposed, and
    the rates are turned back (a pseudovector: det(A) A^T)."""
    for direction in ("bottom-top", "left-right", "right-left"):
        b = coded_axes(direction)
        assert np.allclose(b @ b.T, np.eye(3))
    # A camera yawing in the coded frame pitches in the transposed one.
    w_coded = np.array([0.0, 1.0, 0.0])
    turn = np.linalg.inv(coded_axes("left-right"))
    assert np.allclose(turn @ w_coded, [-1.0, 0.0, 0.0])
    img = np.arange(12).reshape(3, 4)
    assert to_top_bottom(img, "left-right").shape == (4, 3)


def test_a_calibrated_gyro_is_written_as_it_was_used():
    """--method gyro: the log turned into the camera's axes, on the clip's clock from 0."""
    t = np.arange(0, 2, 0.005)
    rate = np.stack([np.sin(t), np.cos(t), 0.1 * t], axis=1)
    axes = Rotation.from_euler("z", 90, degrees=True).as_matrix().round()
    time, cam = log_rates(t, rate, axes, offset=0.4, span=1.0, direction="top-bottom")
    assert time[0] == 0.0 and time[-1] <= 1.1 + 1e-9
    inside = (t > 0.4) & (t <= 1.5)
    assert np.allclose(cam[1:], rate[inside] @ axes.T)


def test_files_are_not_overwritten_and_names_are_checked(exported, tmp_path):
    *_, traj, _, proj, _, _ = exported
    with pytest.raises(OutputError, match="exists"):
        export_project(traj, proj, video=proj.with_suffix(".mp4"), fps=FPS,
                       lens=ProjectLens(FOCAL), frames=N)
    with pytest.raises(SettingsError, match="ends .gyroflow"):
        export_project(traj, tmp_path / "clip.json", video=tmp_path / "c.mp4", fps=FPS,
                       lens=ProjectLens(FOCAL), frames=N)
    (paths, said) = export_project(traj, proj, video=proj.with_suffix(".mp4"), fps=FPS,
                                   lens=ProjectLens.guess(SIZE[0]), frames=N, overwrite=True)
    assert "guessed (70 degrees" in said
    assert not [p for p in proj.parent.iterdir() if p.name.startswith(".")]


def test_gcsv_header_fits_telemetry_parsers_window():
    """frame_readout_time must sit in the first 500 bytes, however long the clip's name."""
    text = gcsv_text(np.zeros(2), np.zeros((2, 3)), readout_ms=15.7, direction="top-bottom",
                     lens=ProjectLens(1000.0), video="/a/" + "x" * 400 + ".mp4", note="n" * 300)
    head = text.encode()[:500].decode(errors="ignore")
    assert "frame_readout_time,15.7000" in head and "frame_readout_direction,TopToBottom" in head
