import av
import numpy as np
import pytest

from unjello.config import CorrectionConfig
from unjello.errors import InputError, OutputError
from unjello.io.video import frame_planes, probe
from unjello.pipeline import correct_video

from ..clips import audio_packets, make_clip, video_pts


def test_audio_pts_and_count_kept(tmp_path, scene):
    src, dst = tmp_path / "in.mp4", tmp_path / "out.mp4"
    make_clip(src, scene, n=10)
    before = src.read_bytes()
    traj = correct_video(src, dst, CorrectionConfig(readout=1.0))
    assert src.read_bytes() == before  # input untouched
    assert len(traj) == 10
    assert video_pts(dst) == video_pts(src)
    a, b = audio_packets(src), audio_packets(dst)
    assert len(a) > 5 and a == b  # bit-identical audio packets, same pts
    assert not list(tmp_path.glob(".*unjello*"))  # no temp file left


def test_variable_frame_rate_pts_kept(tmp_path, scene):
    src, dst = tmp_path / "vfr.mp4", tmp_path / "out.mp4"
    pts = [0, 512, 1536, 2048, 2560, 4096, 4608, 5120]
    make_clip(src, scene, n=8, pts=pts, audio=False)
    traj = correct_video(src, dst)
    assert video_pts(dst) == video_pts(src) == pts
    # Motion uses real timestamps: frame starts in nominal frame intervals.
    starts = [f.start for f in traj.frames]
    assert starts[2] - starts[1] == pytest.approx(2 * (starts[1] - starts[0]), rel=0.05)


def test_rotation_and_colour_kept(tmp_path, scene):
    src, dst = tmp_path / "rot.mp4", tmp_path / "out.mp4"
    make_clip(src, scene, n=6, rotation=90, audio=False)
    correct_video(src, dst, CorrectionConfig(direction="top-bottom"))
    a, b = probe(src), probe(dst)
    assert b.rotation == a.rotation == 90
    assert (b.width, b.height) == (a.width, a.height)  # coded orientation kept
    assert b.frames == a.frames


def test_correction_improves_the_video(tmp_path, scene):
    src, dst = tmp_path / "in.mp4", tmp_path / "out.mp4"
    make_clip(src, scene, n=8, speed=7.0, audio=False)
    traj = correct_video(src, dst, CorrectionConfig(readout="33.333ms"))
    assert traj.timing.readout == pytest.approx(1.0, abs=1e-3)
    v = np.array([f.velocity[:, 0].mean() for f in traj.frames])
    assert np.allclose(v, 7.0, atol=0.3)


def test_ten_bit_kept(tmp_path, scene):
    src, dst = tmp_path / "in10.mp4", tmp_path / "out.mp4"
    make_clip(src, scene, n=5, audio=False, pix_fmt="yuv420p10le")
    correct_video(src, dst)
    with av.open(str(dst)) as c:
        assert c.streams.video[0].codec_context.pix_fmt == "yuv420p10le"


def test_bad_inputs(tmp_path, scene):
    txt = tmp_path / "fake.mp4"
    txt.write_text("not a video")
    with pytest.raises(InputError):
        correct_video(txt, tmp_path / "o.mp4")
    with pytest.raises(InputError):
        correct_video(tmp_path / "missing.mp4", tmp_path / "o.mp4")
    good = tmp_path / "good.mp4"
    make_clip(good, scene, n=4, audio=False)
    with pytest.raises(OutputError):
        correct_video(good, good, overwrite=True)
    existing = tmp_path / "exists.mp4"
    existing.write_bytes(b"keep me")
    with pytest.raises(OutputError):
        correct_video(good, existing)
    assert existing.read_bytes() == b"keep me"


def test_colour_tags_kept(tmp_path, scene):
    src, dst = tmp_path / "tagged.mp4", tmp_path / "out.mp4"
    with av.open(str(src), "w") as out:
        vs = out.add_stream("libx264", rate=30)
        vs.width, vs.height, vs.pix_fmt = 192, 144, "yuv420p"
        cc = vs.codec_context
        cc.color_primaries, cc.color_trc, cc.colorspace, cc.color_range = 1, 1, 1, 1  # BT.709
        for i in range(4):
            img = np.ascontiguousarray(scene[i * 4:i * 4 + 144, :192])
            for p in vs.encode(av.VideoFrame.from_ndarray(img, format="rgb24")
                               .reformat(format="yuv420p")):
                out.mux(p)
        for p in vs.encode():
            out.mux(p)
    a = probe(src).color
    correct_video(src, dst)
    b = probe(dst).color
    assert int(a["color_primaries"]) == 1 and int(a["colorspace"]) == 1
    assert {k: int(v) for k, v in a.items()} == {k: int(v) for k, v in b.items()}


def _luma_levels(path):
    """The first frame's luma 1st/50th/99th percentiles, as decoded (8-bit scale)."""
    with av.open(str(path)) as c:
        frame = next(c.decode(video=0))
        y = frame_planes(frame)[0].astype(np.float64)
        if "10" in frame.format.name:
            y = y / 4
        return np.percentile(y, [1, 50, 99]), frame.color_range


@pytest.mark.parametrize("pix_fmt, codec, suffix", [
    ("yuvj420p", "libx264", ".mp4"), ("yuv420p", "libx264", ".mp4"),
    ("yuvj420p", "ffv1", ".mkv"), ("yuvj420p", "prores_ks", ".mov")])
def test_the_output_has_the_inputs_levels(tmp_path, scene, pix_fmt, codec, suffix):
    """Full-range video (GoPros, phones: yuvj420p) keeps its levels and its tag; ProRes,
    which editors read as limited range, gets the same picture at limited levels."""
    src, dst = tmp_path / f"in_{pix_fmt}.mp4", tmp_path / f"out{suffix}"
    make_clip(src, scene, n=4, audio=False, pix_fmt=pix_fmt)
    (a, range_in) = _luma_levels(src)
    correct_video(src, dst, CorrectionConfig(readout=1.0).with_options(codec=codec))
    (b, range_out) = _luma_levels(dst)
    full = pix_fmt == "yuvj420p"
    assert (a[0] < 8) == full  # the input's black is at 0 (full) or 16 (limited)
    if full and codec == "prores_ks":
        assert range_out == 1 and b[0] == pytest.approx(16, abs=2)
        assert b[2] == pytest.approx(16 + a[2] * 219 / 255, abs=3)
        return
    assert range_out == range_in
    assert np.abs(b - a).max() <= 3  # the same levels (the warp moves a little content)
