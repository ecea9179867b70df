"""Every bad input: one clear line, a non-zero exit (or 0 with a warning), input untouched."""

import os

import av
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from unjello.errors import InputError, UnjelloError
from unjello.io.frames import write_image
from unjello.io.video import VideoReader
from unjello.pipeline import correct_video

from .clips import make_clip
from .runner import clean_failure, run


@pytest.fixture(scope="module")
def good(tmp_path_factory, scene):
    p = tmp_path_factory.mktemp("good") / "good.mp4"
    make_clip(p, scene, n=6)
    return p


def _silent_audio(out, frames):
    """Add an AAC stream of ``frames`` silent frames to an open output container."""
    a = out.add_stream("aac", rate=48000)
    for k in range(frames):
        af = av.AudioFrame.from_ndarray(np.zeros((1, 1024), np.float32), format="fltp",
                                        layout="mono")
        af.sample_rate, af.pts = 48000, k * 1024
        for p in a.encode(af):
            out.mux(p)
    for p in a.encode():
        out.mux(p)


def test_truncated_mp4(tmp_path, good):
    bad = tmp_path / "trunc.mp4"
    bad.write_bytes(good.read_bytes()[: int(good.stat().st_size * 0.3)])
    line = clean_failure(run("correct", bad, "-o", tmp_path / "o.mp4"))
    assert "trunc.mp4" in line


def test_audio_only(tmp_path):
    path = tmp_path / "audio.m4a"
    with av.open(str(path), "w") as out:
        _silent_audio(out, 8)
    line = clean_failure(run("correct", path, "-o", tmp_path / "o.mp4"))
    assert "no video stream" in line


def test_single_frame_copied_with_warning(tmp_path, scene):
    src = tmp_path / "one.mp4"
    make_clip(src, scene, n=1, audio=False)
    res = run("correct", src, "-o", tmp_path / "o.mp4")
    assert res.returncode == 0 and "single frame" in res.stderr
    assert "Traceback" not in res.stderr


def test_odd_size(tmp_path):
    src = tmp_path / "odd.mp4"
    with av.open(str(src), "w") as out:
        vs = out.add_stream("libx264", rate=30)
        vs.width, vs.height, vs.pix_fmt = 161, 121, "yuv444p"
        rng = np.random.default_rng(0)
        for _ in range(4):
            img = rng.integers(0, 255, (121, 161, 3), dtype=np.uint8)
            for p in vs.encode(av.VideoFrame.from_ndarray(img, format="rgb24")
                               .reformat(format="yuv444p")):
                out.mux(p)
        for p in vs.encode():
            out.mux(p)
    res = run("correct", src, "-o", tmp_path / "o.mp4", "-q")
    assert res.returncode == 0, res.stderr


def test_output_folder_missing(tmp_path, good):
    line = clean_failure(run("correct", good, "-o", tmp_path / "nope" / "o.mp4"))
    assert "does not exist" in line


@pytest.mark.skipif(os.geteuid() == 0, reason="root can write into read-only folders")
def test_output_folder_not_writable(tmp_path, good):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    line = clean_failure(run("correct", good, "-o", ro / "o.mp4"))
    assert "not writable" in line


def test_interrupt_leaves_nothing(tmp_path, good):
    dst = tmp_path / "o.mp4"
    before = good.read_bytes()

    def stop(done, total):
        if done >= 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        correct_video(good, dst, progress=stop, preview=tmp_path / "p.mp4",
                      stmap=tmp_path / "st")
    assert not dst.exists() and not (tmp_path / "p.mp4").exists()
    assert not (tmp_path / "st").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == []
    assert good.read_bytes() == before


def test_bad_preset(tmp_path, good):
    line = clean_failure(run("correct", good, "-o", tmp_path / "o.mp4", "--preset", "nope"))
    assert "preset" in line


@settings(max_examples=40, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.binary(min_size=0, max_size=4096), cut=st.floats(0.0, 1.0))
def test_reader_fuzz(tmp_path_factory, good, data, cut):
    # Random bytes, or a good file cut short and followed by random bytes: only clean errors.
    d = tmp_path_factory.mktemp("fuzz")
    head = good.read_bytes()[: int(good.stat().st_size * cut)]
    path = d / "f.mp4"
    path.write_bytes(head + data)
    try:
        with VideoReader(path) as r:
            for _ in r.packets():
                pass
    except UnjelloError as exc:
        assert isinstance(exc, InputError)


def test_video_with_zero_frames(tmp_path):
    path = tmp_path / "zero.mkv"
    with av.open(str(path), "w") as out:
        vs = out.add_stream("mpeg4", rate=30)
        vs.width, vs.height, vs.pix_fmt = 160, 120, "yuv420p"
        _silent_audio(out, 4)
    line = clean_failure(run("correct", path, "-o", tmp_path / "o.mkv"))
    assert "no frames" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["zero.mkv"]


@pytest.mark.slow
def test_ctrl_c_removes_partial_output(tmp_path, scene):
    import signal
    import subprocess
    import sys
    import time

    src = tmp_path / "long.mp4"
    make_clip(src, scene, n=150, size=(320, 240), audio=False)
    proc = subprocess.Popen([sys.executable, "-m", "unjello", "correct", str(src), "-o",
                             str(tmp_path / "o.mp4"), "-q"], stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 60
    while time.time() < deadline and not list(tmp_path.glob(".o.unjello-*")):
        time.sleep(0.05)
    time.sleep(0.2)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "interrupted" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["long.mp4"]


def test_video_output_onto_a_folder_is_refused(tmp_path, good):
    (tmp_path / "dir").mkdir()
    (tmp_path / "dir" / "keep.txt").write_text("x")
    line = clean_failure(run("correct", good, "-o", tmp_path / "dir", "-y"))
    assert "is a folder" in line
    assert (tmp_path / "dir" / "keep.txt").exists()


def test_output_inside_input_folder_is_refused(tmp_path, scene):
    from unjello.io.frames import write_image

    src = tmp_path / "frames"
    src.mkdir()
    for i in range(2):
        write_image(src / f"{i}.png", scene[:128, :128])
    line = clean_failure(run("correct", src, "-o", src / "out"))
    assert "inside the input folder" in line


def test_folder_with_frames_of_different_channels(tmp_path, scene):
    # Same size, RGB then RGBA (a research folder with its masks and flows beside the
    # frames): the line must say what differs, not repeat the same size twice.
    src = tmp_path / "frames"
    src.mkdir()
    small = np.ascontiguousarray(scene[:64, :96])
    write_image(src / "a.png", small)
    write_image(src / "b.png", np.dstack([small, np.full(small.shape[:2], 255, np.uint8)]))
    line = clean_failure(run("correct", src, "-o", tmp_path / "out"))
    assert "3 channels" in line and "4 channels" in line
