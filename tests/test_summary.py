"""A run's findings as fields (unjello.summary), and the lines said of them."""

import numpy as np

from unjello.config import CorrectionConfig
from unjello.run.batch import run_job
from unjello.summary import summarize
from unjello.timing import SensorTiming
from unjello.trajectory import Diagnostics, FrameMotion, Reframe, Trajectory

from .clips import make_clip


def _frame(i, ok=True, reframe=None, **said):
    z = np.zeros((8, 2))
    return FrameMotion(i, float(i), z, z, ok=ok, reframe=reframe or Reframe(),
                       diagnostics=Diagnostics(**said))


def test_the_summary_reads_the_frames_fields():
    traj = Trajectory(SensorTiming(0.9), (16, 8), method="dense", vibration=0.004, frames=[
        _frame(0, ok=False), _frame(1, kept=0.05, folds=0.01, spun=0.02),
        _frame(2, fallback=0.3, entering=0.05, reframe=Reframe(zoom=1.1, shift=(3.0, -2.0))),
        _frame(3)])
    found = summarize(traj, (0.3, "auto"))
    assert found.frames == 4 and found.bridged == 1 and found.vibration == 0.004
    assert found.kept == ((1, 0.05),) and found.folded == ((1, 0.01),) and found.spun == (1,)
    assert np.isclose(found.fallback, 0.075) and np.isclose(found.entering, 0.0125)
    assert found.stabilized["zoom"] == [1.0, 1.1]
    assert found.stabilized["largest_shift"] == [3.0, 2.0]
    lines = found.warnings()
    assert len(lines) == 5  # bridged, vibration, kept, folded, stabilised
    # A kept object is said as the output shows it (whole), not as a warning of a repair.
    assert sum(line.startswith("warning:") for line in lines) == 2
    kept = next(line for line in lines if "kept whole" in line)
    assert "is shown whole" in kept and "folded or tore" not in kept
    assert summarize(Trajectory(SensorTiming(), (16, 8), frames=[_frame(0)])).warnings() == []


def test_what_no_frame_saw_is_said_and_given():
    """Issue 38: frames showing, beyond the edge, what no frame saw are listed, over 0.5 %."""
    traj = Trajectory(SensorTiming(), (16, 8), frames=[
        _frame(0, unseen=0.004), _frame(1, unseen=0.02), _frame(2, unseen=0.031)])
    found = summarize(traj)
    assert found.unseen == ((1, 0.02), (2, 0.031))
    line = next(line for line in found.warnings() if "no frame saw" in line)
    assert "2 frame(s)" in line and "3.1% of frame 2" in line
    assert found.as_json(traj)["unseen"] == [0.004, 0.02, 0.031]
    back = FrameMotion.from_dict(traj.frames[2].to_dict())
    assert back.diagnostics.unseen == 0.031


def test_batch_lines_carry_the_warnings(scene, tmp_path):
    src = tmp_path / "clip.mp4"
    make_clip(src, scene, n=6, size=(160, 120))
    row = run_job(str(src), str(tmp_path / "out.mp4"),
                  CorrectionConfig(readout=1.0).with_options(stabilize=True), False)
    assert row["status"] == "ok"
    assert any(line.startswith("stabilised:") for line in row["warnings"])
