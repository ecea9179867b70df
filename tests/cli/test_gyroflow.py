"""``correct --gyroflow-out`` and ``export-gyroflow``: the project beside the clip."""

import json

import numpy as np
import pytest

from unjello.trajectory import Trajectory

from ..clips import make_clip
from ..runner import clean_failure, run

pytest.importorskip("telemetry_parser", reason="telemetry-parser is a default dependency "
                    "on 3.11-3.12 only")


@pytest.fixture(scope="module")
def corrected(scene, tmp_path_factory):
    """A pan clip corrected camera-only, with its motion JSON and its Gyroflow project."""
    work = tmp_path_factory.mktemp("gf")
    clip = work / "clip.mp4"
    make_clip(clip, scene, n=12, size=(192, 144), audio=False)
    res = run("correct", clip, "-o", work / "out.mp4", "--camera-only", "--focal", 200,
              "--motion-out", work / "m.json", "--gyroflow-out", work / "clip.gyroflow", "-q")
    assert res.returncode == 0, res.stderr
    return work, clip, res


def test_correct_writes_the_project_and_log_beside_the_clip(corrected):
    work, clip, res = corrected
    doc = json.loads((work / "clip.gyroflow").read_text())
    assert doc["videofile"] == str(clip.resolve())  # the original, not unjello's output
    assert doc["gyro_source"]["filepath"] == str((work / "clip.gcsv").resolve())
    assert doc["calibration_data"]["fisheye_params"]["camera_matrix"][0][0] == 200.0
    assert (work / "clip.gcsv").read_text().startswith("GYROFLOW IMU LOG")
    assert not [p for p in work.iterdir() if p.name.startswith(".")]


def test_the_gyro_method_finds_the_log_beside_the_clip_and_reproduces_the_motion(corrected):
    """``--method gyro`` alone finds clip.gcsv, takes its axes, clock and lens, and moves
    every scanline as the camera-only correction did (0.05 px a scanline, mean)."""
    work, clip, _ = corrected
    res = run("correct", clip, "-o", work / "g.mp4", "--method", "gyro", "--motion-out",
              work / "g.json", "--json", "-q")
    assert res.returncode == 0, res.stderr
    line = json.loads(res.stdout)
    assert line["gyro"]["used"] and "written by unjello" in line["sources"]["gyro"]
    own = np.stack([f.displacement for f in Trajectory.load(work / "m.json").frames])
    back = np.stack([f.displacement for f in Trajectory.load(work / "g.json").frames])
    assert np.abs(back - own).mean() < 0.05


def test_export_gyroflow_from_the_motion_json(corrected):
    """The motion JSON names its clip and rate: one argument is enough; a lens no one states
    is guessed, and the command says so."""
    work, clip, _ = corrected
    res = run("export-gyroflow", work / "m.json", "-o", work / "again.gyroflow")
    assert res.returncode == 0, res.stderr
    assert "guessed (70 degrees across the width)" in res.stderr
    doc = json.loads((work / "again.gyroflow").read_text())
    assert doc["videofile"] == str(clip.resolve()) and (work / "again.gcsv").is_file()
    again = run("export-gyroflow", work / "m.json", "-o", work / "again.gyroflow")
    assert "exists" in clean_failure(again)


@pytest.mark.parametrize("args, says", [
    (["missing.json"], "no such file"),
    (["clip.mp4"], "cannot read trajectory"),
    (["m.json", "--video", "nowhere.mp4"], "give --video"),
    (["m.json", "-o", "x.json"], "ends .gyroflow"),
])
def test_export_gyroflow_bad_input_is_one_line(corrected, monkeypatch, args, says):
    work, _, _ = corrected
    monkeypatch.chdir(work)
    assert says in clean_failure(run("export-gyroflow", *args))


def test_a_project_cannot_be_written_for_a_pipe_or_a_segmented_run(corrected):
    work, clip, _ = corrected
    res = run("correct", clip, "-o", work / "s.mp4", "--segments", "2", "--gyroflow-out",
              work / "s.gyroflow")
    assert "--gyroflow-out cannot be written by a segmented run" in clean_failure(res)
