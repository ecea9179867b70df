"""The command line: every bad input is one clear line and a non-zero exit."""

import json

import numpy as np
import pytest

from unjello.io.frames import read_image, write_image
from unjello.simulate import Motion, simulate
from unjello.timing import SensorTiming
from unjello.trajectory import Trajectory

from ..clips import make_clip, motion_file_error
from ..runner import clean_failure, run, run_process


@pytest.fixture(scope="module")
def clip(tmp_path_factory, scene):
    p = tmp_path_factory.mktemp("clip") / "in.mp4"
    make_clip(p, scene, n=6)
    return p


def test_missing_input(tmp_path):
    line = clean_failure(run_process("correct", tmp_path / "nope.mp4", "-o", tmp_path / "o.mp4"))
    assert "no such file" in line


def test_text_file_renamed_mp4(tmp_path):
    fake = tmp_path / "fake.mp4"
    fake.write_text("hello")
    line = clean_failure(run_process("correct", fake, "-o", tmp_path / "o.mp4"))
    assert "not a video" in line
    assert fake.read_text() == "hello"
    assert not (tmp_path / "o.mp4").exists()


@pytest.mark.parametrize("readout", ["0", "-1", "2", "abc"])
def test_bad_readout(tmp_path, clip, readout):
    line = clean_failure(run("correct", clip, "-o", tmp_path / "o.mp4", "--readout", readout))
    assert "readout" in line
    assert not (tmp_path / "o.mp4").exists()


def test_output_equals_input(clip):
    before = clip.read_bytes()
    line = clean_failure(run("correct", clip, "-o", clip, "-y"))
    assert "is the input" in line
    assert clip.read_bytes() == before


def test_existing_output_kept_without_y(tmp_path, clip):
    out = tmp_path / "o.mp4"
    out.write_bytes(b"precious")
    line = clean_failure(run("correct", clip, "-o", out))
    assert "-y" in line
    assert out.read_bytes() == b"precious"


def test_empty_folder(tmp_path):
    (tmp_path / "empty").mkdir()
    line = clean_failure(run("correct", tmp_path / "empty", "-o", tmp_path / "out"))
    assert "no images" in line


# Motion estimated on the frame, or on a copy half its width (as HD video always is):
# measured 25.0 -> 36.4 dB either way; 25.3 when the copy's field was misapplied.
@pytest.mark.parametrize("work", [[], ["--work-width", "96"], ["--edge-refine"]])
def test_simulate_correct_evaluate(tmp_path, scene, work):
    src = tmp_path / "scene.png"
    write_image(src, scene)
    rs, gs = tmp_path / "rs.mp4", tmp_path / "gs.mp4"
    res = run("simulate", src, "-o", rs, "--truth", gs, "--motion", "pan", "--readout", "0.8",
              "--frames", "8", "--size", "192x144", "--speed", "6.5")
    assert res.returncode == 0, res.stderr
    assert (tmp_path / "gs.mp4.motion.json").exists()
    out, motion = tmp_path / "out.mp4", tmp_path / "motion.json"
    res = run("correct", rs, "-o", out, "--readout", "0.8", "--motion-out", motion, "-q",
              *work)
    assert res.returncode == 0, res.stderr
    res = run("evaluate", out, gs, "--motion", motion, "--json", "--margin", "8")
    assert res.returncode == 0, res.stderr
    report = json.loads(res.stdout)
    mean = report["mean"]
    assert mean["displacement_error"] * 8 <= mean["uncorrected_error"]
    res_unc = run("evaluate", rs, gs, "--json", "--margin", "8")
    assert mean["psnr"] > json.loads(res_unc.stdout)["mean"]["psnr"] + 6


def test_version_and_every_option_has_its_flag():
    from unjello import __version__
    from unjello.config import OPTIONS, CorrectionConfig

    assert run("--version").stdout.strip() == f"unjello, version {__version__}"
    correct, batch = run("correct", "--help").stdout, run("batch", "--help").stdout
    for opt in OPTIONS.values():
        assert opt.flag in correct
        assert (opt.flag in batch) != opt.per_clip, opt.name
    # The defaults shown are the library's own, not a copy of them.
    assert f"[default: {CorrectionConfig().dense.work_width}]" in " ".join(correct.split())


def test_readout_in_ms_uses_the_clips_own_frame_rate(tmp_path, scene):
    """36 ms on a 25 fps clip is 0.9 of a frame (was refused against an assumed 30 fps)."""
    src = tmp_path / "c25.mp4"
    make_clip(src, scene, n=6, fps=25)
    res = run("correct", src, "-o", tmp_path / "o.mp4", "--readout", "36ms", "--json")
    assert res.returncode == 0, res.stderr
    doc = json.loads(res.stdout)
    assert doc["readout"] == pytest.approx(0.9, abs=1e-3)
    assert doc["sources"] == {"readout": "command line", "fps": "the video",
                              "direction": "default", "reference": "default"}
    assert doc["frame_rate"] == pytest.approx(25.0, abs=0.01)
    # More than a frame interval at this clip's rate is refused, in one line.
    line = clean_failure(run("correct", src, "-o", tmp_path / "p.mp4", "--readout", "41ms"))
    assert "41 ms is 1.025 of the frame interval at 25" in line


def test_readout_in_ms_for_a_folder_needs_its_frame_rate(tmp_path, scene):
    src = tmp_path / "frames"
    src.mkdir()
    for i, s in enumerate(simulate(scene, Motion("pan", speed=5.0), SensorTiming(0.9), 4,
                                   size=(160, 120))):
        write_image(src / f"f{i}.png", s.rolling)
    line = clean_failure(run("correct", src, "-o", tmp_path / "o", "--readout", "36ms"))
    assert "needs the frame rate" in line and "--fps" in line
    res = run("correct", src, "-o", tmp_path / "o", "--readout", "36ms", "--fps", "25",
              "--json")
    assert res.returncode == 0, res.stderr
    assert json.loads(res.stdout)["readout"] == pytest.approx(0.9)


@pytest.mark.parametrize("value, readout", [
    (0.9, 0.9), ("0.9", 0.9), ("27ms", 0.81), ("auto", None), (None, 1.0)])
@pytest.mark.slow
def test_batch_preset_readout_as_number_string_time_auto_or_missing(tmp_path, clip, value,
                                                                    readout):
    """A JSON preset's readout: a number ended in a traceback (AttributeError: strip)."""
    src = tmp_path / "in"
    src.mkdir()
    (src / "a.mp4").write_bytes(clip.read_bytes())
    preset = tmp_path / "p.json"
    preset.write_text(json.dumps({} if value is None else {"readout": value}))
    res = run_process("batch", src, "-o", tmp_path / "out", "--preset", preset,
                      "--workers", "1")
    assert res.returncode == 0, res.stderr
    assert "Traceback" not in res.stderr
    row = json.loads((tmp_path / "out" / "unjello-batch.jsonl").read_text())
    assert row["status"] == "ok"
    if readout is not None:
        assert row["readout"] == pytest.approx(readout, abs=1e-3)


@pytest.mark.parametrize("preset, message", [
    ({"readout": [0.9]}, "readout must be a number"),
    ({"readout": "fast"}, "cannot parse readout"),
    ({"crf": "high"}, "--crf 'high' is not an integer"),
    ({"speed": 3}, "unknown setting(s) speed"),
])
def test_a_bad_preset_value_is_one_line(tmp_path, clip, preset, message):
    p = tmp_path / "p.json"
    p.write_text(json.dumps(preset))
    line = clean_failure(run("correct", clip, "-o", tmp_path / "o.mp4", "--preset", p))
    assert message in line and str(p) in line
    assert not (tmp_path / "o.mp4").exists()


def test_readout_command(shared_data):
    res = run("readout", shared_data / "readout" / "led_1khz_nikon1j1_1080p30.png",
              "--frequency", "1000", "--fps", "30")
    assert res.returncode == 0, res.stderr
    assert "15.7" in res.stdout and "--readout 0.47" in res.stdout


@pytest.mark.slow
def test_correct_with_auto_readout(tmp_path, scene):
    src = tmp_path / "scene.png"
    write_image(src, scene)
    rs, gs = tmp_path / "rs.mp4", tmp_path / "gs.mp4"
    res = run("simulate", src, "-o", rs, "--truth", gs, "--motion", "shake", "--readout",
              "0.6", "--frames", "12", "--size", "320x240")
    assert res.returncode == 0, res.stderr
    out, motion = tmp_path / "out.mp4", tmp_path / "m.json"
    res = run("correct", rs, "-o", out, "--readout", "auto", "--motion-out", motion, "--json")
    assert res.returncode == 0, res.stderr
    summary = json.loads(res.stdout)
    assert "readout estimated" in summary["messages"][0]
    assert abs(json.loads(motion.read_text())["readout"] - 0.6) <= 0.05


def test_preset_file_and_command_line_wins(tmp_path, clip):
    preset = tmp_path / "cam.json"
    preset.write_text(json.dumps({"readout": "0.7", "method": "paper",
                                  "x264-preset": "ultrafast"}))
    res = run("correct", clip, "-o", tmp_path / "a.mp4", "--preset", preset, "--json")
    assert res.returncode == 0, res.stderr
    doc = json.loads(res.stdout)
    assert doc["readout"] == 0.7 and doc["method"] == "paper"
    res = run("correct", clip, "-o", tmp_path / "b.mp4", "--preset", preset, "--readout",
              "0.5", "--json")
    assert json.loads(res.stdout)["readout"] == 0.5


def test_preset_fast_is_camera_only(tmp_path, clip):
    motion = tmp_path / "m.json"
    res = run("correct", clip, "-o", tmp_path / "f.mp4", "--preset", "fast", "--motion-out",
              motion, "--json")
    assert res.returncode == 0, res.stderr
    doc = json.loads(motion.read_text())
    assert doc["frames"] and all("field" not in f for f in doc["frames"])


def test_vibration_on_a_clip_shorter_than_its_window(tmp_path, clip, scene):
    res = run("correct", clip, "-o", tmp_path / "v.mp4", "--preset", "drone", "--json",
              "--motion-out", tmp_path / "m.json")
    assert res.returncode == 0, res.stderr
    assert json.loads(res.stdout)["frames"] == 6
    # Six frames of a 16-frame window still correct the pan (the clip's own truth).
    sim = list(simulate(scene, Motion("pan", speed=6.0), SensorTiming(1.0), 6,
                        size=(192, 144)))
    err, unc = motion_file_error(tmp_path / "m.json", sim)
    assert err < 0.2 * unc


def test_probe_json(clip):
    res = run("probe", clip, "--json")
    assert res.returncode == 0, res.stderr
    doc = json.loads(res.stdout)
    assert doc["width"] == 192 and doc["audio_streams"] == 1
    assert doc["variable_frame_rate"] is False and doc["readout_ms"] is None


def test_probe_describes_a_folder_of_frames(tmp_path, scene):
    src = tmp_path / "frames"
    src.mkdir()
    for i in range(3):
        write_image(src / f"{i}.png", np.ascontiguousarray(scene[:96, :128]))
    res = run("probe", src)
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith(f"{src}: a folder of 3 PNG frames, 128x96, 3 channel(s)")
    doc = json.loads(run("probe", src, "--json").stdout)
    assert doc["folder"] and doc["frames"] == 3 and doc["fps"] is None


def test_the_last_line_names_every_output_and_the_readouts_source(tmp_path, clip):
    res = run("correct", clip, "-o", tmp_path / "o.mp4", "--preview", tmp_path / "p.mp4",
              "--motion-out", tmp_path / "m.json.gz")
    assert res.returncode == 0, res.stderr
    last = res.stderr.strip().splitlines()[-1]
    assert last.startswith(f"wrote {tmp_path / 'o.mp4'} ")
    assert f"and {tmp_path / 'p.mp4'} (side by side)" in last
    assert f"and {tmp_path / 'm.json.gz'} (motion)" in last
    # A readout the footage could not tell says so, not a bare "default".
    still = tmp_path / "still"
    still.mkdir()
    for i in range(4):
        write_image(still / f"{i}.png", np.ascontiguousarray(scene_still(i)))
    res = run("correct", still, "-o", tmp_path / "still_out", "--readout", "auto")
    assert res.returncode == 0, res.stderr
    assert "readout 1 (default: the footage could not tell it)" in res.stderr


def scene_still(i):
    """A flat grey frame with a fixed square: nothing moves."""
    img = np.full((96, 128, 3), 90, np.uint8)
    img[30:60, 40:80] = 200
    return img


@pytest.mark.slow
def test_plot_command(tmp_path, clip):
    motion = tmp_path / "m.json"
    assert run("correct", clip, "-o", tmp_path / "o.mp4", "--motion-out", motion,
               "-q").returncode == 0
    res = run("plot", motion, "-o", tmp_path / "m.png")
    assert res.returncode == 0, res.stderr
    img = read_image(tmp_path / "m.png")
    assert img.shape[:2] == (660, 1100)  # 10 x 6 inches at 110 dpi
    # Both curves are drawn: Matplotlib's tab:blue (x) and tab:orange (y).
    for colour in ((31, 119, 180), (255, 127, 14)):
        assert (np.abs(img[..., :3].astype(int) - colour).sum(axis=-1) < 30).sum() > 500
    assert "exists" in clean_failure(run("plot", motion, "-o", tmp_path / "m.png"))


def test_textureless_video_is_handled(tmp_path):
    import av
    import numpy as np

    src = tmp_path / "flat.mp4"
    with av.open(str(src), "w") as out:
        vs = out.add_stream("libx264", rate=30)
        vs.width, vs.height, vs.pix_fmt = 160, 120, "yuv420p"
        for i in range(4):
            img = np.full((120, 160, 3), 90 + i, np.uint8)
            for p in vs.encode(av.VideoFrame.from_ndarray(img, format="rgb24")):
                out.mux(p)
        for p in vs.encode():
            out.mux(p)
    res = run("correct", src, "-o", tmp_path / "o.mp4", "--json", "--motion-out",
              tmp_path / "m.json")
    assert res.returncode == 0, res.stderr
    doc = json.loads(res.stdout)
    assert doc["frames"] == 4 and doc["folded_frames"] == [] and doc["folds"] == [0.0] * 4
    assert doc["unseen"] == [0.0] * 4  # nothing moved: nothing beyond the edge
    # Nothing to see, nothing moved: every scanline stays where it is.
    frames = Trajectory.load(tmp_path / "m.json").frames
    assert max(np.abs(f.displacement).max() for f in frames) < 0.05


@pytest.mark.slow
def test_correct_with_a_gyro_log(tmp_path, scene):
    """A folder of frames and its gyro log (another clock, other axes): calibrated, corrected."""

    from unjello.gyrolog import axes_matrix
    from unjello.simulate import Motion, gyro_samples, simulate
    from unjello.timing import SensorTiming

    mot = Motion("shake", fps=25.0, amplitude=1.5)
    src = tmp_path / "frames"
    src.mkdir()
    sim = list(simulate(scene, mot, SensorTiming(1.0), 32, size=(192, 144)))
    for i, s in enumerate(sim):
        write_image(src / f"f{i}.png", s.rolling)
    t, rates = gyro_samples(mot, 1500.0, 32 / 25, axes=axes_matrix("Xzy"), start=100.0)
    log = tmp_path / "gyro.csv"
    log.write_text("time_ms,gx,gy,gz\n" + "\n".join(
        f"{1000 * ti:.3f},{a:.6f},{b:.6f},{c:.6f}" for ti, (a, b, c) in zip(t, rates, strict=True)))
    res = run("correct", src, "-o", tmp_path / "out", "--gyro", log, "--fps", 25, "--json",
              "--motion-out", tmp_path / "m.json")
    assert res.returncode == 0, res.stderr
    summary = json.loads(res.stdout)
    assert summary["method"] == "gyro" and summary["frames"] == 32
    assert "offset 100000" in " ".join(summary["messages"])
    err, unc = motion_file_error(tmp_path / "m.json", sim)
    assert err < 0.1 * unc
    # The same log as a sidecar, NAME.gyro.csv beside the input, is found by --method gyro.
    log.rename(tmp_path / "frames.gyro.csv")
    res = run("correct", src, "-o", tmp_path / "out2", "--method", "gyro", "--fps", 25, "--json")
    assert res.returncode == 0, res.stderr
    assert json.loads(res.stdout)["method"] == "gyro"


@pytest.mark.parametrize("args, message", [
    (["--method", "gyro"], "needs a gyro log"),
    (["--gyro", "nolog.csv"], "cannot read the gyro log"),
    (["--gyro", "in.mp4"], "not a gyro log"),
    (["--gyro", "in.mp4", "--method", "paper"], "goes with --method gyro"),
    (["--gyro", "in.mp4", "--gyro-axes", "XYY"], "gyro axes"),
])
def test_gyro_mistakes_are_one_line(tmp_path, clip, args, message):
    args = [str(clip) if a == "in.mp4" else a for a in args]
    line = clean_failure(run("correct", clip, "-o", tmp_path / "out.mp4", *args))
    assert message in line
    assert not (tmp_path / "out.mp4").exists()


def test_correct_a_video_with_its_gyro_log_keeps_frames_and_audio(tmp_path, scene):
    """A video and a sidecar log: its frame rate from the container, frames and audio kept."""

    from unjello.simulate import Motion, gyro_samples, simulate
    from unjello.timing import SensorTiming

    from ..clips import audio_packets, video_pts

    src = tmp_path / "pan.mp4"
    pts = make_clip(src, scene, n=32, fps=25, speed=6.0)
    t, rates = gyro_samples(Motion("pan", fps=25.0, speed=6.0), 1500.0, 32 / 25, start=3.0)
    (tmp_path / "pan.gyro.csv").write_text("\n".join(
        f"{ti:.6f},{a:.7f},{b:.7f},{c:.7f}" for ti, (a, b, c) in zip(t, rates, strict=True)))
    out = tmp_path / "out.mp4"
    res = run("correct", src, "-o", out, "--method", "gyro", "--json",
              "--motion-out", tmp_path / "m.json")
    assert res.returncode == 0, res.stderr
    assert video_pts(out) == pts
    assert audio_packets(out) == audio_packets(src)
    sim = list(simulate(scene, Motion("pan", speed=6.0), SensorTiming(1.0), 32, size=(192, 144)))
    err, unc = motion_file_error(tmp_path / "m.json", sim)
    assert err < 0.1 * unc


@pytest.mark.slow
def test_simulate_writes_a_gyro_log_that_corrects_its_clip(tmp_path, scene):
    """simulate --gyro-out, then correct --method gyro (the log beside the clip), evaluate."""
    src = tmp_path / "scene.png"
    write_image(src, scene)
    rs, gs, log = tmp_path / "rs.mp4", tmp_path / "gs.mp4", tmp_path / "rs.gyro.csv"
    res = run("simulate", src, "-o", rs, "--truth", gs, "--motion", "shake", "--readout", "0.9",
              "--frames", "40", "--size", "192x144", "--amplitude", "1.5", "--gyro-out", log)
    assert res.returncode == 0, res.stderr
    assert log.read_text().startswith("t,x,y,z")
    out, motion = tmp_path / "out.mp4", tmp_path / "motion.json"
    res = run("correct", rs, "-o", out, "--readout", "0.9", "--method", "gyro",
              "--motion-out", motion, "--json")
    assert res.returncode == 0, res.stderr
    assert "offset 0.0 ms" in " ".join(json.loads(res.stdout)["messages"])
    mean = json.loads(run("evaluate", out, gs, "--motion", motion, "--json").stdout)["mean"]
    # Measured: 0.031x the uncorrected error, 29.7 -> 38.6 dB (whole frame, 640x360, 90
    # frames, README); here 192x144 and 40 frames.
    assert mean["displacement_error"] * 8 <= mean["uncorrected_error"]
    unc = json.loads(run("evaluate", rs, gs, "--json").stdout)["mean"]["psnr"]
    assert mean["psnr"] > unc + 6
    again = run("simulate", src, "-o", rs, "--truth", gs, "--gyro-out", log)
    assert "exists" in clean_failure(again)


@pytest.mark.slow
def test_probe_reports_the_readout_and_lens_correct_uses(shared_data, tmp_path):
    src = shared_data / "sequences" / "gopro_gpmf" / "karma.mp4"
    doc = json.loads(run("probe", src, "--json").stdout)
    assert doc["readout_source"].startswith("camera database")
    assert doc["readout_ms"] == pytest.approx(16.68, abs=0.01)
    assert doc["lens"]["focal"] > 0 and len(doc["lens"]["distortion"]) == 4
    res = run("correct", src, "-o", tmp_path / "o.mp4", "--preset", "fast", "--json", "-q")
    said = json.loads(res.stdout)
    assert said["readout"] == pytest.approx(doc["readout"], abs=1e-6)
    assert said["sources"]["readout"] == doc["readout_source"]
    # A footage that cannot tell its readout: no preset, and the line says that the
    # camera database knows this camera (what correct takes by itself).
    line = clean_failure(run("estimate-readout", src, "--frames", "20", "--save-preset",
                             tmp_path / "p.json"))
    assert "no preset written" in line and "default 1" not in line
    assert "correct takes its readout by itself (camera database: GoPro HERO5 Black" in line


def _ts(path, size, n, scene, first):
    """A rolling-shutter pan as an MPEG transport stream, its frames' pts from ``first``."""
    from fractions import Fraction

    import av

    frames = [s.rolling for s in simulate(scene, Motion("pan", speed=5.0), SensorTiming(0.9),
                                          n, size=size)]
    with av.open(str(path), "w", format="mpegts") as out:
        vs = out.add_stream("libx264", rate=30)
        vs.width, vs.height = size
        vs.pix_fmt = "yuv420p"
        vs.options = {"crf": "16", "preset": "ultrafast"}
        for i, f in enumerate(frames):
            vf = av.VideoFrame.from_ndarray(f, format="rgb24")
            vf.pts, vf.time_base = first + i, Fraction(1, 30)
            for p in vs.encode(vf):
                out.mux(p)
        for p in vs.encode():
            out.mux(p)
    return path.read_bytes()


def test_a_stream_that_changes_its_picture_size_is_scaled_and_broken_there(tmp_path):
    # Two transport streams joined, as recorders and live captures do: 320x180, then
    # 256x144. The second part is scaled to the first size (as ffmpeg does), with one
    # warning, and its motion starts again (no flow across the change).
    from skimage import data

    joined = tmp_path / "joined.ts"
    joined.write_bytes(_ts(tmp_path / "a.ts", (320, 180), 8, data.astronaut(), 0)
                       + _ts(tmp_path / "b.ts", (256, 144), 8, data.coffee(), 8))
    res = run("correct", joined, "-o", tmp_path / "out.mp4", "--json")
    assert res.returncode == 0, res.stderr
    assert res.stderr.count("the picture size changed part-way (256x144)") == 1
    doc = json.loads(res.stdout)
    assert doc["frames"] == 16
    assert [(s["first"], s["last"], s["why"]) for s in doc["stretches"]] == [
        (0, 7, "start"), (8, 15, "size")]
    assert all(s["model"] == "smooth" for s in doc["stretches"])


def test_a_stream_whose_timestamps_start_over_is_carried_on_and_broken_there(tmp_path):
    # Two transport streams joined whose timestamps both start at 0: carried on (the
    # output's keep increasing), one warning, and the motion starts again there.
    import av
    from skimage import data

    joined = tmp_path / "joined.ts"
    joined.write_bytes(_ts(tmp_path / "a.ts", (320, 180), 8, data.astronaut(), 0)
                       + _ts(tmp_path / "b.ts", (320, 180), 8, data.coffee(), 0))
    res = run("correct", joined, "-o", tmp_path / "out.mp4", "--json")
    assert res.returncode == 0, res.stderr
    assert res.stderr.count("timestamps started over 1 time(s)") == 1
    doc = json.loads(res.stdout)
    assert [(s["first"], s["why"]) for s in doc["stretches"]] == [(0, "start"), (8, "time")]
    with av.open(str(tmp_path / "out.mp4")) as c:
        pts = [f.pts for f in c.decode(video=0)]
    assert len(pts) == 16 and all(b > a for a, b in zip(pts, pts[1:], strict=False))


def test_probe_estimates_the_readout_and_lens_from_a_turning_camera(tmp_path):
    """``probe --estimate``: a camera turning about three axes through a 220 px pinhole,
    read in 0.5 of the frame interval: the readout and the lens it fits."""
    from skimage import data

    from unjello.simulate import simulate_rotation

    world = np.concatenate([data.astronaut(), data.astronaut()[::-1]], axis=0)

    def rate(t):
        t = np.asarray(t)[..., None]
        return np.sin(2 * np.pi * np.array([1.3, 2.1, 0.9]) * t + np.array([0.0, 1.0, 2.0]))

    sim, _ = simulate_rotation(world, rate, SensorTiming(0.5), 12, size=(320, 256),
                               focal=220.0)
    src = tmp_path / "frames"
    src.mkdir()
    for i, f in enumerate(sim):
        write_image(src / f"{i:02d}.png", np.ascontiguousarray(f.rolling[..., :3]))
    res = run("probe", src, "--estimate", "--json")
    assert res.returncode == 0, res.stderr
    doc = json.loads(res.stdout)["estimate"]
    assert doc["reliable"] and doc["model"] == "rotation"
    assert doc["readout"] == pytest.approx(0.5, abs=0.05)
    assert doc["lens"]["focal"] == pytest.approx(220.0, rel=0.15)
    # estimate-readout with the lens known: that lens, not a fitted one.
    known = run("estimate-readout", src, "--focal", "220")
    assert known.returncode == 0, known.stderr
    assert "pinhole f 220" in known.stdout and "fitted to the motion" not in known.stdout
    line = clean_failure(run("estimate-readout", src, "--distortion", "0,0,0,0"))
    assert line == "unjello: error: --distortion needs --focal: the lens's focal length in pixels"
