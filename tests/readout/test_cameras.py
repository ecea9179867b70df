"""The camera database: the packaged table, search, matching, and the readout it gives."""

import gzip
import importlib.util
import json
import sys
from pathlib import Path

import pytest

from unjello.clip import resolve_timing
from unjello.config import CorrectionConfig
from unjello.errors import SettingsError
from unjello.readout import cameras

from ..clips import make_clip
from ..runner import clean_failure, run

ROOT = Path(__file__).resolve().parents[2]


def test_the_table_says_where_it_comes_from():
    raw = (ROOT / "src" / "unjello" / "data" / "cameras.json.gz").read_bytes()
    doc = json.loads(gzip.decompress(raw))
    assert doc["licence"].startswith("CC0") and "lens_profiles" in doc["source"]
    assert len(cameras.table()) == len(doc["rows"]) > 9000
    assert sum(1 for m in cameras.table() if m.readout_ms) > 1000


def test_the_packaged_table_is_what_the_script_builds(shared_data, tmp_path):
    source = shared_data / "lens_profiles" / "gyroflow_lens_profiles.jsonl.gz"
    spec = importlib.util.spec_from_file_location("camera_table",
                                                  ROOT / "scripts" / "camera_table.py")
    script = importlib.util.module_from_spec(spec)
    sys.modules["camera_table"] = script
    spec.loader.exec_module(script)
    built = script.build(source)
    packaged = json.loads(gzip.decompress(
        (ROOT / "src" / "unjello" / "data" / "cameras.json.gz").read_bytes()))
    assert built == packaged


def test_search_and_the_noisy_hero5():
    """The HERO5 Black's 16:9 30 fps profiles disagree (16.7 twice, 26.7, 33.4 ms): the
    match takes the value most of them agree on (one they state, not a mean between
    them) and says how many agree."""
    modes = cameras.search("hero5 black wide")
    assert modes and all("HERO5 Black" in m.model and "Wide" in m.mode for m in modes)
    found = cameras.match("GoPro HERO5 Black", 854, 480, 29.97)
    assert found.camera == "GoPro HERO5 Black" and found.direction == "top-bottom"
    assert found.profiles == 4 and found.agree == 2
    assert found.spread == pytest.approx((16.68, 33.3667), abs=1e-3)
    assert found.readout_ms == pytest.approx(16.68, abs=0.01)
    assert "1.78:1 modes at 29.97 fps" in found.modes
    assert 300 < found.focal < 800  # a wide lens on an 854 px wide picture
    assert found.same_aspect and "none is" not in found.modes
    # 2.7K 60 fps: one profile, at that rate.
    assert cameras.match("HERO5 Black", 2704, 2028, 59.94).readout_ms == pytest.approx(8.3417)
    assert cameras.match("No Such Camera 3000") is None


def test_a_name_of_several_cameras_is_refused(tmp_path):
    with pytest.raises(SettingsError, match="matches .* cameras"):
        cameras.match("iPhone 1")
    with pytest.raises(SettingsError, match="matches .* cameras"):  # a user's typing
        resolve_timing(CorrectionConfig(camera="GoPro"), path=tmp_path / "c.mp4",
                       video_fps=29.97, size=(854, 480))


def test_a_camera_the_file_names_vaguely_is_a_hint(tmp_path):
    """A trimmed GoPro file names only its brand: the cameras it fits are pooled; where
    they disagree the default is used, with one warning, never an error."""
    pooled = cameras.match("GoPro", 854, 480, 29.97, family=True)
    assert pooled.camera.startswith("GoPro (") and pooled.profiles > 4
    clip = tmp_path / "c.mp4"
    clip.write_bytes(b"")
    res = resolve_timing(CorrectionConfig(), path=clip, video_fps=29.97, size=(854, 480),
                         identified="GoPro")
    warnings = [m for m in res.messages if m.startswith("warning")]
    assert len(warnings) == 1 and "names its camera only as 'GoPro'" in warnings[0]
    if 2 * pooled.agree > pooled.profiles:
        assert res.sources["readout"].startswith("camera database (GoPro (")
    else:
        assert res.sources["readout"] == "default" and "disagree" in warnings[0]


def test_a_trimmed_gopro_clip_is_corrected(shared_data, tmp_path):
    """A cut that keeps the telemetry track but not the camera's model (ffmpeg -c copy)."""
    pytest.importorskip("telemetry_parser", reason="telemetry-parser is not installed")
    src = shared_data / "sequences" / "gopro_gpmf" / "karma.mp4"
    cut = tmp_path / "cut.mp4"
    import av

    with av.open(str(src)) as inp, av.open(str(cut), "w") as out:
        keep = [inp.streams.video[0], inp.streams.audio[0], inp.streams[3]]
        made = {s.index: out.add_stream_from_template(s) for s in keep}
        for packet in inp.demux(*keep):
            if packet.dts is None:
                continue
            if packet.stream.type == "video" and float(packet.pts * packet.time_base) > 1.0:
                break
            packet.stream = made[packet.stream.index]
            out.mux(packet)
    res = run("probe", cut)
    assert res.returncode == 0, res.stderr
    assert "names its camera only as 'GoPro'" in res.stdout
    res = run("correct", cut, "-o", tmp_path / "o.mp4", "--preset", "fast")
    assert res.returncode == 0, res.stderr
    assert sum("names its camera only as" in ln for ln in res.stderr.splitlines()) == 1


def test_the_readout_comes_from_the_database(tmp_path):
    clip = tmp_path / "c.mp4"
    clip.write_bytes(b"")
    cfg = CorrectionConfig(camera="GoPro HERO5 Black")
    res = resolve_timing(cfg, path=clip, video_fps=29.97, size=(854, 480))
    assert res.sources["readout"] == "camera database (GoPro HERO5 Black)"
    assert res.timing.readout == pytest.approx(cameras.match(
        "GoPro HERO5 Black", 854, 480, 29.97).readout_ms * 29.97e-3, abs=1e-6)
    assert any(m.startswith("camera database: GoPro HERO5 Black") for m in res.messages)
    # The camera the file names, when none is given; the command line wins over both.
    res = resolve_timing(CorrectionConfig(), path=clip, video_fps=29.97, size=(854, 480),
                         identified="GoPro HERO5 Black")
    assert res.sources["readout"].startswith("camera database")
    res = resolve_timing(CorrectionConfig(readout=0.5, camera="GoPro HERO5 Black"),
                         path=clip, video_fps=29.97, size=(854, 480))
    assert res.timing.readout == 0.5
    with pytest.raises(SettingsError, match="no readout"):
        resolve_timing(CorrectionConfig(camera="No Such Camera 3000"), path=clip,
                       video_fps=30.0)


def test_a_lens_profile_gives_its_readout(tmp_path, scene):
    clip = tmp_path / "c.mp4"
    make_clip(clip, scene, n=3)
    profile = tmp_path / "lens.json"
    profile.write_text(json.dumps({"name": "x", "frame_readout_time": 15.0,
                                   "fisheye_params": {"camera_matrix": [[1, 0, 0]] * 3}}))
    res = run("correct", clip, "-o", tmp_path / "out.mp4", "--lens-profile", profile, "--json")
    assert res.returncode == 0, res.stderr
    summary = json.loads(res.stdout)
    assert summary["sources"]["readout"] == "lens profile lens.json"
    assert summary["readout"] == pytest.approx(0.45)
    (tmp_path / "empty.json").write_text("{}")
    res = run("correct", clip, "-o", tmp_path / "o2.mp4", "--lens-profile",
              tmp_path / "empty.json", "--json")
    assert res.returncode == 0, res.stderr
    assert "states no frame_readout_time" in " ".join(json.loads(res.stdout)["messages"])
    (tmp_path / "bad.json").write_text("{not json")
    line = clean_failure(run("correct", clip, "-o", tmp_path / "o3.mp4", "--lens-profile",
                             tmp_path / "bad.json"))
    assert "not a lens profile" in line


def test_the_cameras_command():
    res = run("cameras", "hero5", "black")
    assert res.returncode == 0 and "HERO5 Black" in res.stdout and "8.342 ms" in res.stdout
    # A bottom-to-top profile is said so, not as a negative readout.
    assert "-16.68" not in res.stdout and "bottom-top" in res.stdout
    # The modes a clip's readout rests on, marked, and the line correct prints for it:
    # the same readout as a row of the table.
    res = run("cameras", "hero5", "black", "--size", "854x480", "--fps", "29.97")
    assert res.returncode == 0, res.stderr
    marked = [ln for ln in res.stdout.splitlines() if ln.startswith("*")]
    assert len(marked) == 4 and all("29.97" in ln for ln in marked)
    said = res.stdout.splitlines()[-1]
    assert said.startswith("a 854x480 clip at 29.97 fps gets: camera database: GoPro HERO5")
    assert "readout 16.68 ms (2 of 4" in said and any("16.68 ms" in ln for ln in marked)
    res = run("cameras", "hero5", "black", "--json")
    rows = [json.loads(line) for line in res.stdout.splitlines()]
    assert rows and all(r["readout_ms"] for r in rows)
    assert "no camera" in clean_failure(run("cameras", "nonexistentcam"))


def test_a_gopro_file_names_its_camera(shared_data):
    from unjello.io.telemetry import camera_of

    pytest.importorskip("telemetry_parser", reason="telemetry-parser is not installed")
    folder = shared_data / "sequences" / "gopro_gpmf"
    assert camera_of(folder / "karma.mp4") == "GoPro HERO5 Black"
    assert camera_of(folder / "max-heromode.mp4") == "GoPro Max"


def test_undistort_takes_the_lens_from_the_database(tmp_path, scene):
    clip = tmp_path / "c.mp4"
    make_clip(clip, scene, n=3)
    res = run("correct", clip, "-o", tmp_path / "out.mp4", "--camera", "GoPro HERO5 Black",
              "--undistort", "--json")
    assert res.returncode == 0, res.stderr
    said = " ".join(json.loads(res.stdout)["messages"])
    assert "lens from the camera database (GoPro HERO5 Black): focal" in said
    line = clean_failure(run("correct", clip, "-o", tmp_path / "o2.mp4", "--undistort"))
    assert "undistort needs the lens" in line
