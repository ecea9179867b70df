"""The readout from straight lines, pooled clips, and a database the footage contradicts."""

import json

import cv2
import numpy as np
import pytest
from click.testing import CliRunner

from unjello.cli.commands import cli
from unjello.clip import resolve_timing
from unjello.config import CorrectionConfig
from unjello.io.frames import write_image
from unjello.motion.flow.dis import FlowSettings, flow_pair
from unjello.readout.cameras import CameraMatch
from unjello.readout.footage import (
    MOTION_SIGMA,
    ReadoutEstimate,
    _combine,
    estimate_readout,
    pool_estimates,
)
from unjello.readout.lines import CONFIDENT, frame_segments, line_readout
from unjello.simulate import Motion, simulate, street_scene
from unjello.timing import SensorTiming, to_top_bottom

FLOW = FlowSettings("medium", finest_scale=1, refinement=None, consistency=10.0)


@pytest.fixture(scope="module")
def street():
    return street_scene((960, 720))


def _clip(scene, motion, rho, direction="top-bottom", n=12):
    return [s.rolling for s in simulate(scene, motion, SensorTiming(rho, direction), n,
                                        size=(320, 240))]


def _lines(frames, direction="top-bottom"):
    grey = [cv2.cvtColor(to_top_bottom(f, direction), cv2.COLOR_RGB2GRAY).astype(np.float32)
            for f in frames]
    flows = [flow_pair(grey[k], grey[k + 1], FLOW, 640, two_way=True)[2]
             for k in range(len(grey) - 1)]
    return line_readout(grey, np.arange(len(grey), dtype=float), flows)


def test_segments_lean_as_the_shutter_skews_them(street):
    # A pan of 8 px per frame interval at rho 0.6 leans verticals by 8 * 0.6 / 240 = 0.02.
    frame = _clip(street, Motion("pan", speed=8.0), 0.6, n=1)[0]
    segs, roll = frame_segments(cv2.cvtColor(frame, cv2.COLOR_RGB2GRAY))
    assert len(segs) > 30 and (roll is None or abs(roll) < 0.005)
    assert np.median(segs[:, 2]) == pytest.approx(0.02, abs=0.003)


@pytest.mark.parametrize("rho, direction", [(0.3, "top-bottom"), (0.9, "top-bottom"),
                                            (0.6, "bottom-top")])
def test_hand_shake_gives_the_readout_from_tracked_lines(street, rho, direction):
    # Measured: within 0.03 at 0.3 ... 1.0 in both directions, with sigma 0.016-0.041.
    cue = _lines(_clip(street, Motion("shake"), rho, direction), direction)
    assert cue.kind == "tracked" and cue.tracks >= 8
    assert cue.uncertainty < 0.045 and cue.readout == pytest.approx(rho, abs=0.05)


def test_a_leaning_rolled_scene_changes_nothing_when_tracked():
    scene = street_scene((960, 720), lean=0.03, roll=0.05)
    cue = _lines(_clip(scene, Motion("shake"), 0.7))
    assert cue.confident and cue.readout == pytest.approx(0.7, abs=0.05)


@pytest.mark.parametrize("n", [2, 12])
def test_without_a_change_of_velocity_the_lines_are_not_trusted(street, n):
    # A steady pan, or two frames: only the prior that verticals are vertical is left,
    # and a real scene's own lean (0.09 RMS) makes it unknown at 8 px per frame.
    frames = _clip(street, Motion("pan", speed=8.0), 0.6, n=n)
    cue = _lines(frames)
    assert cue.kind == "vertical prior" and not cue.confident
    assert cue.readout == pytest.approx(0.6, abs=0.1)  # right here: the scene is upright
    est = estimate_readout(frames)
    assert not est.reliable and est.readout == 1.0 and np.isfinite(est.uncertainty)


def test_the_motion_goes_first_and_the_lines_check_it(street):
    est = estimate_readout(_clip(street, Motion("shake"), 0.5))
    assert est.reliable and est.cue == "motion" and est.uncertainty == MOTION_SIGMA
    assert est.readout == pytest.approx(0.5, abs=0.05)
    assert est.lines_agree is True
    # Where the motion cannot tell, confident lines are the estimate: the motion cue's
    # shortest candidate (no minimum inside the range) is taken as "cannot tell".
    motion = ReadoutEstimate(1.0, 0.2, False, np.zeros(0), np.zeros(0))
    lines = _lines(_clip(street, Motion("shake"), 0.5))
    alone = _combine(motion, lines, 1.0)
    assert alone.reliable and alone.cue == "lines" and alone.uncertainty <= CONFIDENT
    assert alone.readout == pytest.approx(0.5, abs=0.05)


def _est(guess, sigma):
    empty = np.zeros(0)
    return ReadoutEstimate(1.0, 0.0, False, empty, empty, cue="none", uncertainty=sigma,
                           best_guess=guess)


def test_pooling_weighs_by_uncertainty():
    pooled = pool_estimates([_est(0.84, 0.03), _est(0.86, 0.03), _est(0.85, 0.03),
                             _est(0.2, 1.0)])
    assert pooled.reliable and pooled.cue == "pooled"
    assert pooled.readout == pytest.approx(0.85, abs=0.01)
    assert pooled.uncertainty == pytest.approx(0.03 / np.sqrt(3), rel=0.05)
    # Clips that disagree beyond their uncertainties widen it (Birge ratio).
    split = pool_estimates([_est(0.5, 0.01), _est(0.9, 0.01)])
    assert not split.reliable and split.uncertainty > 0.1
    assert not pool_estimates([_est(float("nan"), float("inf"))]).reliable


def test_estimate_readout_pools_clips_and_saves_a_preset(street, tmp_path):
    folders = []
    for k, motion in enumerate((Motion("shake"), Motion("shake", amplitude=0.7))):
        folder = tmp_path / f"clip{k}"
        folder.mkdir()
        for i, frame in enumerate(_clip(street, motion, 0.6)):
            write_image(folder / f"{i:03d}.png", frame)
        folders.append(str(folder))
    preset = tmp_path / "cam.json"
    runner = CliRunner()
    out = runner.invoke(cli, ["estimate-readout", *folders, "--save-preset", str(preset),
                              "--json"])
    assert out.exit_code == 0, out.output
    found = json.loads(out.output)
    assert found["reliable"] and found["cue"] == "pooled" and len(found["inputs"]) == 2
    assert found["readout"] == pytest.approx(0.6, abs=0.05)
    saved = json.loads(preset.read_text())  # folders state no frame rate: a fraction
    assert saved["readout"] == pytest.approx(found["readout"], abs=1e-3)
    assert CorrectionConfig.from_preset(preset).readout == pytest.approx(saved["readout"])
    again = runner.invoke(cli, ["estimate-readout", *folders, "--save-preset", str(preset)])
    assert again.exit_code != 0 and "exists" in again.output  # not without -y
    still = tmp_path / "still"
    still.mkdir()
    for i, frame in enumerate(_clip(street, Motion("pan", speed=0.0), 0.6, n=4)):
        write_image(still / f"{i:03d}.png", frame)
    none = runner.invoke(cli, ["estimate-readout", str(still), "--save-preset",
                               str(tmp_path / "no.json")])
    assert none.exit_code != 0 and "no preset written" in none.output
    assert not (tmp_path / "no.json").exists()


def test_a_database_readout_the_footage_contradicts_is_reported(street, tmp_path,
                                                                 monkeypatch):
    # The clip's readout is 0.5; a (deliberately wrong) database entry, on which all its
    # profiles agree, says 33.3 ms at 30 fps: 1.0.
    wrong = CameraMatch("Test Cam", 33.3, "top-bottom", 3, 3, (33.3, 33.3),
                        "its 4:3 modes at 30 fps", same_aspect=True)
    monkeypatch.setattr("unjello.clip.match", lambda *a, **k: wrong)
    frames = _clip(street, Motion("shake"), 0.5)
    (tmp_path / "clip.mp4").write_bytes(b"")
    kw = {"path": tmp_path / "clip.mp4", "video_fps": 30.0, "size": (320, 240),
          "identified": "Test Cam",
          "estimate": lambda direction, fps: estimate_readout(frames, direction=direction)}
    told = resolve_timing(CorrectionConfig(), **kw)
    assert told.timing.readout == pytest.approx(0.999, abs=0.01)  # the database's, as asked
    assert told.sources["readout_check"] == "the footage disagrees"
    warning = [m for m in told.messages if m.startswith("warning")]
    assert len(warning) == 1 and "camera database (Test Cam)" in warning[0]
    auto = resolve_timing(CorrectionConfig(readout="auto"), **kw)
    assert auto.timing.readout == pytest.approx(0.5, abs=0.05)
    assert auto.sources["readout"].startswith("estimated from the motion")
    assert auto.estimate.uncertainty <= CONFIDENT
