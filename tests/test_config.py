"""Settings resolved once: presets from Python, flat options, the timing's order and sources."""

import dataclasses
import json
import re
from pathlib import Path

import numpy as np
import pytest

from unjello.clip import resolve_timing
from unjello.config import OPTIONS, PRESETS, CorrectionConfig
from unjello.errors import SettingsError
from unjello.readout.footage import MOTION_SIGMA, ReadoutEstimate
from unjello.timing import Milliseconds, SensorTiming


def _Estimate(readout, reliable=True):
    return ReadoutEstimate(readout, 0.8 if reliable else 0.1, reliable, np.zeros(0),
                           np.zeros(0), cue="motion" if reliable else "none",
                           uncertainty=MOTION_SIGMA if reliable else float("inf"),
                           best_guess=readout if reliable else float("nan"))


def test_presets_are_library_objects(tmp_path):
    drone = CorrectionConfig.from_preset("drone")
    assert drone.dense.vibration == "on" and drone.method == "dense"
    fast = CorrectionConfig.from_preset("fast")
    assert not fast.dense.per_pixel and fast.dense.work_width == 320
    assert fast.option("camera_only") is True
    p = tmp_path / "my.json"
    p.write_text(json.dumps({"readout": "36ms", "method": "paper", "x264-preset": "fast",
                             "gyro_offset": 250}))
    mine = CorrectionConfig.from_preset(p)
    assert mine.readout == Milliseconds(36.0) and mine.method == "paper"
    assert mine.encode.preset == "fast" and mine.gyro.offset == pytest.approx(0.25)
    assert mine.option("gyro_offset") == pytest.approx(250)
    assert mine.origins["readout"] == "preset my.json"
    # A preset applied to other settings keeps what it does not name.
    assert CorrectionConfig.from_preset("drone", base=mine).method == "paper"
    assert set(PRESETS) == {"paper-figures", "fast", "drone", "handheld", "best"}
    # The default flow is polished (DIS down to half resolution, refined at full), and
    # the full one where it does not explain a pair; --preset best always the full one,
    # the default until issue 37.
    full = CorrectionConfig.from_preset("best").dense.flow
    assert (full.finest_scale, full.refinement, full.polish, full.fallback) == (None, 1, 0, None)
    checked = CorrectionConfig().dense.flow
    assert (checked.finest_scale, checked.refinement, checked.polish) == (1, 3, 1)
    assert checked.fallback == full
    polished = CorrectionConfig().with_options(flow_detail="polished").dense.flow
    assert polished == dataclasses.replace(checked, fallback=None)


@pytest.mark.parametrize("value, parsed", [
    (0.9, 0.9), ("0.9", 0.9), (1, 1.0), ("36ms", Milliseconds(36.0)), (" Auto ", "auto"),
    (None, None)])
def test_a_readout_is_parsed_once_whatever_its_form(value, parsed):
    config = CorrectionConfig().with_options(readout=value)
    assert config.readout == parsed
    # Never a string again: the request is a number, a time or 'auto'.
    assert not isinstance(config.readout, str) or config.readout == "auto"


@pytest.mark.parametrize("values, message", [
    ({"readout": 1.5}, "outside (0, 1]"),
    ({"readout": "-3ms"}, "positive"),
    ({"readout": True}, "readout must be a number"),
    ({"direction": "diagonal"}, "direction must be one of"),
    ({"search": 0}, "search range"),
    ({"crf": 60}, "crf must be 0 to 51"),
    ({"crf": 3.5}, "crf=3.5 is not an integer"),
    ({"camera_only": "maybe"}, "camera_only='maybe' is not true or false"),
    ({"vibration": "maybe"}, "vibration must be auto, on or off"),
    ({"flow_preset": "slow"}, "flow preset must be one of"),
    ({"gyro": "x.csv", "method": "paper"}, "gyro= goes with method=gyro"),
    ({"colour": "red"}, "unknown setting(s) colour"),
])
def test_the_library_validates_every_option(values, message):
    with pytest.raises(SettingsError, match=message.replace("(", r"\(").replace(")", r"\)")):
        CorrectionConfig().with_options(**values)


def test_a_gyro_log_means_the_gyro_method():
    config = CorrectionConfig().with_options(gyro="x.csv")
    assert config.method == "gyro" and config.gyro.path == "x.csv"


def test_option_table_paths_all_resolve():
    defaults = CorrectionConfig()
    for name in OPTIONS:
        defaults.option(name)  # raises AttributeError on a stale path


def _resolve(config, tmp_path, video_fps=30.0, **kw):
    return resolve_timing(config, path=tmp_path / "clip.mp4", video_fps=video_fps, **kw)


def test_defaults_and_their_sources(tmp_path):
    r = _resolve(CorrectionConfig(), tmp_path)
    assert r.timing == SensorTiming(1.0, "top-bottom", "middle") and r.fps == 30.0
    assert dict(r.sources) == {"fps": "the video", "direction": "default",
                               "reference": "default", "readout": "default"}


def test_order_of_precedence(tmp_path):
    clip = tmp_path / "clip.mp4"
    clip.write_bytes(b"")
    (tmp_path / "clip.mp4.readout.json").write_text(json.dumps({"frame_readout_time": 15.0}))
    estimate = lambda direction, fps: _Estimate(0.42)  # noqa: E731
    # The sidecar beats the default, and 'auto' takes it before estimating.
    for readout in (None, "auto"):
        r = _resolve(CorrectionConfig(readout=readout), tmp_path, estimate=estimate)
        assert r.timing.readout == pytest.approx(0.45)
        assert r.sources["readout"] == "sidecar clip.mp4.readout.json"
        assert "15 ms from the sidecar" in r.messages[0]
    # The settings beat the sidecar, and say who gave them.
    given = CorrectionConfig().with_options(origin="command line", readout=0.7,
                                            reference="first")
    r = _resolve(given, tmp_path, estimate=estimate)
    assert r.timing.readout == 0.7 and r.timing.reference == "first"
    assert r.sources["readout"] == "command line" and r.sources["reference"] == "command line"
    # A motion file beats everything.
    r = _resolve(given, tmp_path, motion_timing=SensorTiming(0.3, "left-right"))
    assert r.timing == SensorTiming(0.3, "left-right") and r.sources["readout"] == "motion file"


def test_auto_estimates_when_nothing_states_it(tmp_path):
    r = _resolve(CorrectionConfig(readout="auto"), tmp_path,
                 estimate=lambda direction, fps: _Estimate(0.42))
    assert r.timing.readout == 0.42 and r.sources["readout"].startswith("estimated from the motion")
    weak = _resolve(CorrectionConfig(readout="auto"), tmp_path,
                    estimate=lambda direction, fps: _Estimate(1.0, reliable=False))
    assert weak.sources["readout"] == "default: the footage could not tell it"
    assert weak.messages[0].startswith("warning")


def test_a_readout_borrowed_from_another_aspect_goes_after_a_reliable_estimate(tmp_path):
    # The GoPro Max's only mode with a readout is its 360 one (4096x1344); a hero-mode
    # clip (848x480) borrows it by default, says so, and with 'auto' a reliable estimate
    # from the clip's motion goes first.
    kw = {"size": (848, 480), "identified": "GoPro Max", "video_fps": 29.97}
    r = _resolve(CorrectionConfig(), tmp_path, **kw)
    assert r.sources["readout"] == "camera database (GoPro Max)"
    assert "(4096x1344; none is 1.77:1)" in r.messages[0]
    r = _resolve(CorrectionConfig(readout="auto"), tmp_path,
                 estimate=lambda direction, fps: _Estimate(0.42), **kw)
    assert r.timing.readout == 0.42 and r.sources["readout"].startswith("estimated from the motion")
    assert "no mode of GoPro Max like this clip's" in r.messages[0]
    weak = _resolve(CorrectionConfig(readout="auto"), tmp_path,
                    estimate=lambda direction, fps: _Estimate(0.42, reliable=False), **kw)
    assert weak.sources["readout"] == "camera database (GoPro Max)"
    assert weak.timing.readout == pytest.approx(1.0)
    # A clip of the camera's own aspect takes the database's readout, checked against
    # the footage: 16.68 ms (what two of its four profiles say) at 29.97 fps is 0.5 of the
    # frame interval; the profiles' spread (0.5-1.0) is what the footage is checked with.
    kw5 = {"size": (854, 480), "identified": "GoPro HERO5 Black", "video_fps": 29.97}
    hero5 = _resolve(CorrectionConfig(readout="auto"), tmp_path,
                     estimate=lambda direction, fps: _Estimate(0.64), **kw5)
    assert hero5.sources["readout"] == "camera database (GoPro HERO5 Black)"
    assert hero5.sources["readout_check"] == "the footage agrees"
    # Where the footage contradicts it, it says so; with 'auto' the footage goes first.
    for readout in (None, "auto"):
        off = _resolve(CorrectionConfig(readout=readout), tmp_path,
                       estimate=lambda direction, fps: _Estimate(0.3), **kw5)
        assert off.sources["readout_check"] == "the footage disagrees"
        warning = [m for m in off.messages if m.startswith("warning")]
        # Its four profiles disagree (16.7-33.4 ms): their spread is its uncertainty.
        assert len(warning) == 1 and "0.500-1.000" in warning[0] and "say 0.300" in warning[0]
        assert off.timing.readout == pytest.approx(0.3 if readout else 0.5, abs=0.01)


def test_one_frame_rate_for_a_folder(tmp_path):
    folder = CorrectionConfig(readout="36ms")
    with pytest.raises(SettingsError, match="needs the frame rate: a folder states none"):
        _resolve(folder, tmp_path, video_fps=None)
    r = _resolve(folder.with_options(origin="command line", fps=25), tmp_path, video_fps=None)
    assert r.timing.readout == pytest.approx(0.9) and r.fps == 25.0
    assert r.sources["fps"] == "command line"
    # Without ms, a folder runs at the assumed rate, and says so.
    r = _resolve(CorrectionConfig(), tmp_path, video_fps=None)
    assert r.fps == 30.0 and r.sources["fps"] == "default"
    # A video's own rate turns its ms readout into a fraction.
    r = _resolve(folder, tmp_path, video_fps=25.0)
    assert r.timing.readout == pytest.approx(0.9) and r.sources["fps"] == "the video"


def test_a_config_is_picklable_for_a_cluster():
    import pickle

    config = CorrectionConfig.from_preset("fast").with_options(readout="20ms")
    assert pickle.loads(pickle.dumps(config)) == config


def test_readme_preset_example_runs(tmp_path):
    """The JSON preset shown in the README is a valid preset."""
    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    block = re.search(r'`(\{"readout".*?\})`', readme).group(1)
    p = tmp_path / "p.json"
    p.write_text(block)
    CorrectionConfig.from_preset(p)
