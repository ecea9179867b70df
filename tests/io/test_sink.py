"""Outputs: never the input, nothing overwritten unless asked, nothing partial left."""

import os

import numpy as np
import pytest

from unjello.errors import OutputError
from unjello.io.frames import write_image
from unjello.io.sink import FrameSink, PictureSink, check_paths
from unjello.io.source import FrameSource

from ..clips import make_clip


def test_check_paths_refuses_what_would_clobber(tmp_path):
    clip = tmp_path / "in.mp4"
    clip.write_bytes(b"x")
    with pytest.raises(OutputError, match="is the input"):
        check_paths(clip, tmp_path / "." / "in.mp4", overwrite=True)
    folder = tmp_path / "frames"
    folder.mkdir()
    with pytest.raises(OutputError, match="inside the input folder"):
        check_paths(folder, folder / "out", overwrite=True)
    with pytest.raises(OutputError, match="is a folder; give the output video a file name"):
        check_paths(clip, folder, overwrite=True)
    existing = tmp_path / "out.mp4"
    existing.write_bytes(b"keep")
    with pytest.raises(OutputError, match="exists; pass overwrite=True"):
        check_paths(clip, existing, overwrite=False)
    with pytest.raises(OutputError, match="output folder does not exist"):
        check_paths(clip, tmp_path / "no" / "out.mp4", overwrite=False)
    check_paths(clip, existing, overwrite=True)
    assert existing.read_bytes() == b"keep"


def _hidden(folder):
    return [p.name for p in folder.iterdir() if p.name.startswith(".")]


@pytest.mark.parametrize("kind", ["video", "folder"])
def test_picture_sink_is_atomic(tmp_path, scene, kind):
    if kind == "video":
        src = tmp_path / "in.mp4"
        make_clip(src, scene, n=3, audio=True)
        dst = tmp_path / "out.mp4"
    else:
        src = tmp_path / "in"
        src.mkdir()
        for i in range(3):
            write_image(src / f"f{i}.png", scene[:64, :80])
        dst = tmp_path / "out"
    with FrameSource(src) as source:
        sink = PictureSink(dst, source)
        pics = list(source.pictures())
        sink.write(pics[0], pics[0].planes)
        assert not dst.exists() and len(_hidden(tmp_path)) <= 1  # under a temp name, if yet
        sink.abort()
    assert not dst.exists() and not _hidden(tmp_path)
    with FrameSource(src) as source:
        sink = PictureSink(dst, source)
        for item in source.items():
            if hasattr(item, "planes"):
                sink.write(item, item.planes)
            else:
                sink.copy_audio(item)
        sink.close()
    assert dst.exists() and not _hidden(tmp_path)
    if kind == "folder":
        assert sorted(os.listdir(dst)) == ["f0.png", "f1.png", "f2.png"]


def test_frame_sink_writes_a_folder_or_a_video_and_refuses_to_overwrite(tmp_path):
    frames = [np.full((32, 48, 3), v, np.uint8) for v in (0, 128, 255)]
    for name in ("frames", "clip.mp4"):
        with FrameSink(tmp_path / name, fps=25.0) as sink:
            for f in frames:
                sink.write(f)
        with pytest.raises(OutputError, match="exists"):
            FrameSink(tmp_path / name)
    assert sorted(os.listdir(tmp_path / "frames")) == [f"frame_{i:05d}.png" for i in range(3)]
    with FrameSource(tmp_path / "clip.mp4") as source:
        assert source.info.fps == pytest.approx(25.0) and len(list(source.pictures())) == 3
    with pytest.raises(OutputError, match="even width and height"), \
            FrameSink(tmp_path / "odd.mp4") as sink:
        sink.write(np.zeros((31, 48, 3), np.uint8))
    assert not (tmp_path / "odd.mp4").exists() and not _hidden(tmp_path)
