"""unjello between two ffmpeg commands: standard input and output (NUT, y4m), broken pipes."""

import json
import os
import pty
import shutil
import subprocess
import sys

import av
import numpy as np
import pytest

from tests.clips import audio_packets, make_clip
from unjello.config import CorrectionConfig
from unjello.pipeline import correct_video
from unjello.simulate import Motion, simulate
from unjello.timing import SensorTiming

FFMPEG = shutil.which("ffmpeg")
needs_ffmpeg = pytest.mark.skipif(FFMPEG is None, reason="needs the ffmpeg program "
                                  "(Debian's ffmpeg; .ci/run installs it)")
UNJELLO = f"{sys.executable} -m unjello"


@pytest.fixture(scope="module")
def clip(tmp_path_factory, scene):
    path = tmp_path_factory.mktemp("pipes") / "clip.mp4"
    make_clip(path, scene, n=12, size=(160, 120), audio=True, readout=0.9)
    return path


@pytest.fixture(scope="module")
def on_file(clip, tmp_path_factory):
    """`unjello correct` on the file, lossless, for the frames to compare."""
    out = tmp_path_factory.mktemp("file") / "file.mkv"
    correct_video(clip, out, CorrectionConfig(readout=0.9).with_options(codec="ffv1"))
    return out


def _frames(path):
    with av.open(str(path)) as c:
        vs = c.streams.video[0]
        got = [(float(f.pts * vs.time_base), f.to_ndarray(format="gray").astype(np.float32))
               for f in c.decode(video=0)]
    return [t for t, _ in got], [g for _, g in got]


def _shell(cmd, cwd):
    return subprocess.run(["bash", "-o", "pipefail", "-c", cmd], cwd=cwd, capture_output=True,
                          text=True, timeout=300)


@needs_ffmpeg
@pytest.mark.parametrize("fmt", ["nut", "yuv4mpegpipe"])
def test_between_two_ffmpeg_commands(clip, on_file, tmp_path, fmt):
    out = tmp_path / "out.mkv"
    audio = "-c:a copy" if fmt == "nut" else ""
    res = _shell(f"{FFMPEG} -v error -i {clip} -c copy -f nut - | {UNJELLO} correct - -o - "
                 f"--readout 0.9 --format {fmt} | {FFMPEG} -v error -y -i - -c:v ffv1 {audio} "
                 f"{out}", tmp_path)
    assert res.returncode == 0, res.stderr
    assert "wrote -" in res.stderr  # messages on standard error only
    times, frames = _frames(out)
    ref_times, ref = _frames(on_file)
    src_times, _ = _frames(clip)
    assert len(frames) == len(ref) == len(src_times) == 12
    assert np.allclose(np.diff(times), np.diff(src_times), atol=1e-3)  # every frame's time
    assert max(float(np.abs(a - b).mean()) for a, b in zip(frames, ref, strict=True)) <= 1.0
    if fmt == "nut":  # NUT carries the audio through; y4m is frames only
        assert len(audio_packets(out)) == len(audio_packets(clip))


@needs_ffmpeg
def test_a_reader_that_stops_early_is_one_line(clip, tmp_path):
    res = _shell(f"{UNJELLO} correct {clip} -o - --readout 0.9 | head -c 2000 > /dev/null",
                 tmp_path)
    assert res.returncode == 1
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert lines == ["unjello: the program reading the output stopped (broken pipe)"]


def test_a_terminal_as_output_is_refused(clip, tmp_path):
    leader, follower = pty.openpty()
    try:
        res = subprocess.run([sys.executable, "-m", "unjello", "correct", str(clip), "-o", "-",
                              "--readout", "0.9"], stdout=follower, stderr=subprocess.PIPE,
                             text=True, timeout=120, cwd=tmp_path)
    finally:
        os.close(follower)
        os.close(leader)
    assert res.returncode == 2
    assert res.stderr.strip() == ("unjello: error: standard output is a terminal: pipe it "
                                  "into a program (| ffmpeg -i - ...) or give -o a file")


def test_auto_readout_on_standard_input_is_one_line(clip, tmp_path):
    with open(clip, "rb") as f:
        res = subprocess.run([sys.executable, "-m", "unjello", "correct", "-", "-o",
                              str(tmp_path / "o.mp4"), "--readout", "auto"], stdin=f,
                             capture_output=True, text=True, timeout=120)
    assert res.returncode == 2 and "Traceback" not in res.stderr
    assert "--readout auto reads the clip twice" in res.stderr


@needs_ffmpeg
@pytest.mark.parametrize("pix_fmt", ["yuvj420p", "yuv420p"])
def test_a_pipe_keeps_the_colour_tags_and_levels(tmp_path, scene, pix_fmt):
    """NUT has no field for colour tags: a tagged clip's frames cross the pipe as
    lossless H.264, which carries them, so `| ffmpeg -i - out.mov` keeps range, matrix,
    primaries and transfer, and the same levels."""
    src = tmp_path / "tagged.mp4"
    with av.open(str(src), "w") as out:
        vs = out.add_stream("libx264", rate=30)
        vs.width, vs.height, vs.pix_fmt = 160, 120, pix_fmt
        cc = vs.codec_context
        cc.color_primaries, cc.color_trc, cc.colorspace = 1, 1, 1  # BT.709
        cc.color_range = 2 if pix_fmt == "yuvj420p" else 1
        for s in simulate(scene, Motion("pan", speed=5), SensorTiming(0.9), 8,
                          size=(160, 120)):
            frame = av.VideoFrame.from_ndarray(s.rolling, format="rgb24")
            for p in vs.encode(frame.reformat(format=pix_fmt,
                                              dst_color_range=cc.color_range)):
                out.mux(p)
        for p in vs.encode():
            out.mux(p)
    out = tmp_path / "out.mov"
    res = _shell(f"{FFMPEG} -v error -i {src} -c copy -f nut - | {UNJELLO} correct - -o - "
                 f"--readout 0.9 -q | {FFMPEG} -v error -y -i - -c:v libx264 {out}", tmp_path)
    assert res.returncode == 0, res.stderr
    probe = subprocess.run(["ffprobe", "-v", "error", "-select_streams", "v:0", "-show_entries",
                            "stream=color_range,color_space,color_primaries,color_transfer",
                            "-of", "json", str(out)], capture_output=True, text=True)
    tags = json.loads(probe.stdout)["streams"][0]
    assert tags == {"color_range": "pc" if pix_fmt == "yuvj420p" else "tv",
                    "color_space": "bt709", "color_primaries": "bt709",
                    "color_transfer": "bt709"}
    _, a = _frames(src)
    _, b = _frames(out)
    assert abs(np.percentile(a[3], 99) - np.percentile(b[3], 99)) <= 3
