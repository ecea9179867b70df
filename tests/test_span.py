"""A part of a clip (--start, --duration): its frames, timed from zero, with their audio,
and their motion measured from the frames around them."""

import av
import numpy as np
import pytest

from unjello.config import CorrectionConfig
from unjello.errors import InputError, SettingsError
from unjello.io.frames import write_image
from unjello.pipeline import correct_video
from unjello.preview import PreviewClip
from unjello.timing import ClipSpan, ClipTime, clip_time

from .clips import make_clip
from .runner import clean_failure, run


@pytest.fixture(scope="module")
def clip(tmp_path_factory, scene):
    path = tmp_path_factory.mktemp("span") / "clip.mp4"
    make_clip(path, scene, n=60, size=(192, 144), audio=True, readout=0.9, speed=4)
    return path


@pytest.fixture(scope="module")
def whole(clip, tmp_path_factory):
    out = tmp_path_factory.mktemp("whole") / "whole.mkv"
    correct_video(clip, out, CorrectionConfig(readout=0.9).with_options(codec="ffv1"))
    return out


def _frames(path):
    with av.open(str(path)) as c:
        vs = c.streams.video[0]
        return [(float(f.pts * vs.time_base), f.to_ndarray(format="gray").astype(np.float32))
                for f in c.decode(video=0)]


def _audio_span(path):
    with av.open(str(path)) as c:
        a = c.streams.audio[0]
        times = [float(p.pts * a.time_base) for p in c.demux(a) if p.dts is not None]
        return min(times), max(times), len(times)


def test_clip_times_read_as_ffmpeg_takes_them():
    assert clip_time("12.5") == clip_time("12.5s") == ClipTime(12.5, "s")
    assert clip_time("1:02.5") == ClipTime(62.5) and clip_time("1:00:00") == ClipTime(3600)
    assert clip_time("150f") == clip_time("150 frames") == ClipTime(150, "f")
    assert clip_time("150f").seconds(30) == 5 and clip_time("2").frames(25) == 50
    for bad in ("soon", "-1", "1:xx"):
        with pytest.raises(SettingsError):
            clip_time(bad)
    with pytest.raises(SettingsError, match="more than 0"):
        ClipSpan(duration=ClipTime(0))


@pytest.mark.parametrize("start, duration", [("20f", "15f"), ("0.6667", "0.5")])
def test_a_part_is_the_same_frames_timed_from_zero(clip, whole, tmp_path, start, duration):
    out = tmp_path / "part.mkv"
    config = CorrectionConfig(readout=0.9).with_options(codec="ffv1", start=start,
                                                        duration=duration)
    traj = correct_video(clip, out, config, motion_out=tmp_path / "m.json")
    got, ref = _frames(out), _frames(whole)
    assert len(got) == len(traj) == 15
    times = [t for t, _ in got]
    assert times[0] == 0.0 and np.allclose(np.diff(times), 1 / 30, atol=1e-3)
    # Frames 20-34 of the whole run: measured with the frames around them, the same.
    for (_, a), (_, b) in zip(got, ref[20:35], strict=True):
        assert np.abs(a - b).mean() < 0.5
    assert [f.index for f in traj.frames] == list(range(15))
    assert traj.frames[0].start == 0.0
    # The audio is cut to match: from 0, about half a second of it.
    first, last, packets = _audio_span(out)
    assert first == pytest.approx(0.0, abs=0.03) and last < 0.5
    assert packets == pytest.approx(0.5 * 48000 / 1024, abs=2)


def test_a_part_to_the_end_and_bad_parts(clip, tmp_path):
    out = tmp_path / "tail.mp4"
    correct_video(clip, out, CorrectionConfig(readout=0.9).with_options(start="50f"))
    assert len(_frames(out)) == 10
    with pytest.raises(InputError, match="past the clip's end"):
        correct_video(clip, tmp_path / "x.mp4",
                      CorrectionConfig(readout=0.9).with_options(start="10"))
    assert not (tmp_path / "x.mp4").exists()
    with pytest.raises(SettingsError, match="whole clip"):
        correct_video(clip, tmp_path / "y.mp4",
                      CorrectionConfig(readout=0.9).with_options(start="1"),
                      motion_in=tmp_path / "m.json")


def test_a_part_of_a_folder_keeps_its_names(tmp_path, scene):
    src = tmp_path / "frames"
    src.mkdir()
    for i in range(8):
        write_image(src / f"f{i}.png", np.ascontiguousarray(scene[3 * i:3 * i + 96, :128]))
    res = run("correct", src, "-o", tmp_path / "out", "--start", "2f", "--duration", "3f",
              "-q")
    assert res.returncode == 0, res.stderr
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["f2.png", "f3.png", "f4.png"]


def test_the_command_line_and_the_preview_take_a_part(clip, tmp_path):
    res = run("correct", clip, "-o", tmp_path / "o.mp4", "--start", "1", "--duration", "10f")
    assert res.returncode == 0, res.stderr
    assert "wrote" in res.stderr and "(10 frames" in res.stderr
    line = clean_failure(run("correct", clip, "-o", tmp_path / "o2.mp4", "--start", "later"))
    assert "not a time of the clip" in line
    config = CorrectionConfig(readout=0.9).with_options(start="40f", duration="6f")
    with PreviewClip(clip, config) as preview:
        assert preview.count == 6
        # Its frame 0 is the clip's frame 40 (as read).
        with av.open(str(clip)) as c:
            frame40 = [f.to_ndarray(format="rgb24") for f in c.decode(video=0)][40]
        assert np.array_equal(preview.frame(0), frame40)
        image, _ = preview.corrected(5, preview.initial)
        assert image.shape == frame40.shape
        assert "--start 40f --duration 6f" in preview.command(preview.initial)


def test_a_part_deep_in_a_file_is_entered_by_seeking(tmp_path, scene):
    """Past the look-behind (a second) and a keyframe: the reader seeks, and the part's
    frames are still the whole run's, timed from zero."""
    src = tmp_path / "long.mp4"
    make_clip(src, scene, n=100, size=(160, 120), audio=False, readout=0.9, speed=3,
              keyint=20)
    config = CorrectionConfig(readout=0.9).with_options(codec="ffv1")
    whole, part = tmp_path / "whole.mkv", tmp_path / "part.mkv"
    correct_video(src, whole, config)
    correct_video(src, part, config.with_options(start="2.5", duration="10f"))
    got, ref = _frames(part), _frames(whole)
    assert len(got) == 10 and got[0][0] == 0.0
    for (_, a), (_, b) in zip(got, ref[75:85], strict=True):
        assert np.abs(a - b).mean() < 0.5
