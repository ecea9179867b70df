"""One clip in segments on workers (local processes, Dask, Ray), joined without re-encoding."""

import av
import numpy as np
import pytest

from tests.clips import audio_packets, make_clip, video_pts
from tests.runner import run
from unjello.config import CorrectionConfig
from unjello.errors import SettingsError
from unjello.io.remux import frame_index
from unjello.pipeline import correct_video
from unjello.run.segments import Segment, _Job, correct_segmented, plan_segments, run_segment
from unjello.timing import SensorTiming

# Lossless output, so the frames compare the correction itself, not two encodes.
LOSSLESS = CorrectionConfig(readout=0.9).with_options(crf=0)


@pytest.fixture(scope="module")
def clip(tmp_path_factory, scene):
    path = tmp_path_factory.mktemp("seg") / "long.mp4"
    make_clip(path, scene, n=36, size=(160, 120), keyint=12, speed=5.0, readout=0.9)
    return path


@pytest.fixture(scope="module")
def single(clip, tmp_path_factory):
    out = tmp_path_factory.mktemp("one") / "one.mp4"
    traj = correct_video(clip, out, LOSSLESS)
    return out, traj


def _grey(path):
    with av.open(str(path)) as c:
        return [f.to_ndarray(format="gray").astype(np.float32) for f in c.decode(video=0)]


def _same_as_one_run(out, single, clip):
    one, traj = single
    assert video_pts(out) == video_pts(clip)
    assert audio_packets(out) == audio_packets(clip)
    a, b = _grey(out), _grey(one)
    assert len(a) == len(b) == 36
    assert max(float(np.abs(x - y).mean()) for x, y in zip(a, b, strict=True)) <= 1.0


def test_segments_start_at_keyframes_with_context_both_sides():
    plan = plan_segments(100, (0, 24, 48, 72, 96), 4, 5)
    assert [(s.start, s.end) for s in plan] == [(0, 24), (24, 48), (48, 72), (72, 100)]
    assert [(s.lead, s.tail) for s in plan] == [(0, 29), (19, 53), (43, 77), (67, 100)]
    assert len(plan_segments(50, (0,), 3, 5)) == 1  # one keyframe: one segment


def test_local_segments_give_the_frames_of_one_run(clip, single, tmp_path):
    assert frame_index(clip).keyframes == (0, 12, 24)
    out = tmp_path / "seg.mp4"
    traj, report = correct_segmented(clip, out, LOSSLESS, segments=3, workers=2)
    assert [s["status"] for s in report["segments"]] == ["done"] * 3
    _same_as_one_run(out, single, clip)
    assert [f.index for f in traj.frames] == list(range(36))
    for fa, fb in zip(traj.frames, single[1].frames, strict=True):
        assert np.allclose(fa.displacement, fb.displacement, atol=1e-3)


@pytest.mark.slow
def test_an_interrupted_run_redoes_only_the_unfinished_segments(clip, single, tmp_path,
                                                                 monkeypatch):
    import unjello.run.segments as segments

    out = tmp_path / "seg.mp4"

    def interrupted(*args):
        raise KeyboardInterrupt

    monkeypatch.setattr(segments, "join_segments", interrupted)
    with pytest.raises(KeyboardInterrupt):
        correct_segmented(clip, out, LOSSLESS, segments=3, workers=2)
    assert not out.exists()
    work = tmp_path / ".seg.mp4.segments"
    (work / "part_0001.mp4").unlink()  # as if the run had stopped before it finished
    monkeypatch.undo()
    _, report = correct_segmented(clip, out, LOSSLESS, segments=3, workers=2)
    assert [s["status"] for s in report["segments"]] == ["kept", "done", "kept"]
    assert not work.exists()
    _same_as_one_run(out, single, clip)
    # The output is now there: not replaced without overwrite.
    with pytest.raises(Exception, match="exists"):
        correct_segmented(clip, out, LOSSLESS, segments=3)


def test_a_failed_segment_leaves_nothing_half_written(clip, tmp_path):
    part = tmp_path / "part.mp4"
    pts = tuple(frame_index(clip).pts)
    job = _Job(str(clip), str(part), Segment(0, 0, 40, 0, 36), LOSSLESS, SensorTiming(0.9),
               30.0, pts + (10**9,) * 4, 1)  # asks for frames the clip does not have
    with pytest.raises(Exception, match="decoded 36 of its 40 frames"):
        run_segment(job)
    assert list(tmp_path.iterdir()) == []


def test_the_gyro_method_is_not_split(clip, tmp_path):
    with pytest.raises(SettingsError, match="one run"):
        correct_segmented(clip, tmp_path / "o.mp4", CorrectionConfig(method="gyro"))


@pytest.mark.slow
@pytest.mark.parametrize("kind, extra", [("dask", "distributed"), ("ray", "ray")])
def test_cluster_segments(clip, single, tmp_path, kind, extra):
    pytest.importorskip(extra)
    out = tmp_path / f"{kind}.mp4"
    res = run("correct", clip, "-o", out, "--readout", "0.9", "--crf", "0",
              "--segments", "3", "--executor", kind, "--workers", "2", "-q")
    assert res.returncode == 0, res.stderr
    _same_as_one_run(out, single, clip)


def test_segments_refuse_side_outputs_in_one_line(clip, tmp_path):
    res = run("correct", clip, "-o", tmp_path / "o.mp4", "--segments", "2",
              "--stmap", tmp_path / "st")
    assert res.returncode == 2
    assert "--stmap cannot be written by a segmented run" in res.stderr
    assert "Traceback" not in res.stderr
    res = run("correct", clip, "-o", tmp_path / "o.mp4", "--segments", "zero")
    assert res.returncode == 2 and "Traceback" not in res.stderr
