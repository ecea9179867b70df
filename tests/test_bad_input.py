"""Every bad input: one clear line, a non-zero exit (or 0 with a warning), input untouched."""

import os
from pathlib import Path

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


# The command line as `unjello` runs it, but with Ctrl-C's handler whatever the test run
# inherited: a POSIX shell starts a background job (`make test &`) with SIGINT ignored, and
# Python keeps an ignored SIGINT ignored, so a plain `python -m unjello` child of such a run
# never sees the signal (issue 40: it finished with exit code 0).
_WITH_CTRL_C = ("import signal, sys; signal.signal(signal.SIGINT, signal.default_int_handler); "
                "from unjello.cli.commands import main; main(sys.argv[1:])")


@pytest.mark.parametrize("sig, code, said", [("SIGINT", 130, "interrupted"),
                                             ("SIGTERM", 143, "stopped (SIGTERM)")])
def test_a_signal_removes_partial_output(tmp_path, good, sig, code, said):
    """Stopped mid-run, the run exits 128 + the signal and leaves nothing behind.

    It cannot have finished before the signal, however fast or slow the machine: its
    video goes to standard output, which this test does not read, so it blocks once the
    pipe is full (two of its frames); its motion file and side-by-side preview are partial
    files until then. The encoder's queue is dropped, not waited on.
    """
    import signal
    import subprocess
    import sys
    import time

    proc = subprocess.Popen([sys.executable, "-c", _WITH_CTRL_C, "correct", str(good), "-o",
                             "-", "--readout", "0.9", "--motion-out", "m.json", "--preview",
                             "p.mp4", "-q"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            cwd=tmp_path)
    try:
        deadline = time.time() + 120
        while len(list(tmp_path.glob(".*"))) < 2:  # both partial files are being written
            assert proc.poll() is None and time.time() < deadline
            time.sleep(0.02)
        proc.send_signal(getattr(signal, sig))
        deadline = time.time() + 60
        while proc.poll() is None and time.time() < deadline:
            time.sleep(0.05)
    finally:
        rc = proc.poll()
        proc.kill()
        err = proc.communicate()[1].decode()
    assert rc == code, err
    assert "Traceback" not in err and f"{said}; partial output removed" in err, err
    assert list(tmp_path.iterdir()) == []


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


@pytest.fixture
def refusing_folder(tmp_path, monkeypatch):
    """A folder that the access check passes but that refuses writes (an ACL, a network
    share): a chmod 500 folder, or for root (which writes anywhere) /sys."""
    if os.geteuid() != 0:
        folder = tmp_path / "ro"
        folder.mkdir()
        folder.chmod(0o500)
    else:
        folder = Path("/sys")
        try:
            (folder / ".unjello-probe").touch()
        except OSError:
            pass
        else:
            pytest.skip("/sys is writable here: no folder refuses root's writes")
    import unjello.io.sink as sink

    monkeypatch.setattr(sink.os, "access", lambda *a, **k: True)
    return folder


@pytest.mark.parametrize("name", ["o.mp4", "frames_out"])
def test_an_output_the_folder_refuses_is_one_line(refusing_folder, tmp_path, good, scene,
                                                   name):
    if name == "frames_out":  # a folder of frames makes a folder
        src = tmp_path / "frames"
        src.mkdir()
        for i in range(2):
            write_image(src / f"{i}.png", scene[:64, :96])
    else:
        src = good
    line = clean_failure(run("correct", src, "-o", refusing_folder / name, "-q"))
    assert line == f"unjello: error: cannot write the output: the folder {refusing_folder} " \
                   "is not writable"


def test_a_folder_of_frames_into_a_video_name_makes_a_video(tmp_path, scene):
    src = tmp_path / "frames"
    src.mkdir()
    for i in range(5):
        write_image(src / f"f{i}.png", np.ascontiguousarray(scene[4 * i:4 * i + 96, :128]))
    res = run("correct", src, "-o", tmp_path / "out.mp4", "--fps", "25", "-q")
    assert res.returncode == 0, res.stderr
    assert (tmp_path / "out.mp4").is_file()
    with av.open(str(tmp_path / "out.mp4")) as c:
        vs = c.streams.video[0]
        assert (vs.codec_context.width, vs.codec_context.height) == (128, 96)
        assert vs.average_rate == 25 and sum(1 for _ in c.decode(video=0)) == 5
    odd = tmp_path / "odd"
    odd.mkdir()
    for i in range(2):
        write_image(odd / f"{i}.png", scene[:65, :97])
    line = clean_failure(run("correct", odd, "-o", tmp_path / "odd.mp4"))
    assert "even width and height" in line and not (tmp_path / "odd.mp4").exists()


def test_a_damaged_clip_is_said(tmp_path, good):
    """Random bytes in the middle: the decoder patches over them; the run says how many
    frames were damaged."""
    src = tmp_path / "damaged.mp4"
    data = bytearray(good.read_bytes())
    rng = np.random.default_rng(1)
    middle = len(data) // 2
    data[middle:middle + 200] = rng.integers(0, 256, 200, dtype=np.uint8).tobytes()
    src.write_bytes(bytes(data))
    res = run("correct", src, "-o", tmp_path / "o.mp4", "-q")
    assert res.returncode == 0, res.stderr
    assert "frame(s) of the input were damaged" in res.stderr
    quiet = run("correct", good, "-o", tmp_path / "o2.mp4", "-q")
    assert "damaged" not in quiet.stderr


def test_unreadable_files_say_why_in_the_users_terms(tmp_path, good):
    empty, cut, text = tmp_path / "empty.mp4", tmp_path / "cut.mp4", tmp_path / "notes.mp4"
    empty.write_bytes(b"")
    cut.write_bytes(good.read_bytes()[:300])
    text.write_text("shopping list\n")
    said = {p.name: clean_failure(run("probe", p)) for p in (empty, cut, text)}
    assert said["empty.mp4"].endswith("empty.mp4: the file is empty")
    assert "cut short or damaged" in said["cut.mp4"]
    assert said["notes.mp4"].endswith("not a video file (no container FFmpeg knows)")
    assert not any("PyAV" in s or "InvalidDataError" in s for s in said.values())


def test_frames_too_small_give_the_minimum(tmp_path):
    src = tmp_path / "tiny"
    src.mkdir()
    for i in range(2):
        write_image(src / f"{i}.png", np.zeros((1, 1, 3), np.uint8))
    line = clean_failure(run("correct", src, "-o", tmp_path / "out"))
    assert "1x1 are too small (unjello needs at least 16x16)" in line


def test_a_side_output_the_folder_refuses_is_one_line(refusing_folder, tmp_path, good):
    line = clean_failure(run("correct", good, "-o", tmp_path / "o.mp4", "--motion-out",
                             refusing_folder / "m.json", "-q"))
    assert line == (f"unjello: error: cannot write {refusing_folder / 'm.json'}: the folder "
                    f"{refusing_folder} is not writable")
    assert not (tmp_path / "o.mp4").exists()
