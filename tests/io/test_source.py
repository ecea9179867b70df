"""A frame source: start times from pts (the one place), folders, sizes, bit depth."""

from fractions import Fraction

import numpy as np
import pytest

from unjello.errors import InputError
from unjello.io.frames import write_image
from unjello.io.source import FrameSource, Picture

from ..clips import make_clip


def test_start_times_come_from_the_pts(tmp_path, scene):
    # 30 fps nominal in a 1/15360 time base (512 ticks a frame), with gaps.
    pts = [0, 512, 1536, 2048, 2560, 4096, 4608, 5120]
    src = tmp_path / "vfr.mp4"
    make_clip(src, scene, n=8, pts=pts, audio=True)
    with FrameSource(src) as source:
        info = source.info
        assert info.is_video and (info.width, info.height) == (192, 144)
        assert info.time_base == Fraction(1, 15360) and info.max_value == 255.0
        items = list(source.items())
    pictures = [i for i in items if isinstance(i, Picture)]
    assert [p.pts for p in pictures] == pts
    expected = [p * info.fps / 15360 for p in pts]
    assert [p.start for p in pictures] == pytest.approx(expected)
    assert len(items) > len(pictures)  # the audio packets come along, in file order
    with FrameSource(src) as source:  # another rate: the same times in its frame intervals
        starts = [p.start for p in source.pictures(fps=2 * info.fps, limit=3)]
    assert starts == pytest.approx([2 * e for e in expected[:3]])


def test_a_folder_is_frames_zero_one_two_with_their_names(tmp_path):
    for name in ("f10.png", "f9.png", "f1.png"):
        write_image(tmp_path / name, np.full((20, 24, 3), 7, np.uint8))
    with FrameSource(tmp_path) as source:
        assert not source.info.is_video and source.info.fps is None
        assert source.info.frames == 3
        pics = list(source.pictures())
    assert [(p.name, p.start, p.pts) for p in pics] == [
        ("f1.png", 0.0, None), ("f9.png", 1.0, None), ("f10.png", 2.0, None)]


def test_a_frame_of_another_size_is_named(tmp_path):
    write_image(tmp_path / "a.png", np.zeros((20, 24, 3), np.uint8))
    write_image(tmp_path / "b.png", np.zeros((20, 24), np.uint8))
    with FrameSource(tmp_path) as source, pytest.raises(
            InputError, match=r"b.png: 24x20, 1 channel differs from the first frame's "
                              r"24x20, 3 channels"):
        list(source.pictures())


def test_too_small_or_missing(tmp_path):
    write_image(tmp_path / "a.png", np.zeros((8, 8, 3), np.uint8))
    with pytest.raises(InputError, match="8x8 are too small"):
        FrameSource(tmp_path)
    with pytest.raises(InputError, match="no such file or folder"):
        FrameSource(tmp_path / "nope.mp4")


def test_ten_bit_video_white_level(tmp_path, scene):
    src = tmp_path / "ten.mp4"
    make_clip(src, scene, n=3, audio=False, pix_fmt="yuv420p10le")
    with FrameSource(src) as source:
        assert source.info.max_value == 1023.0
        luma = next(source.pictures()).planes[0]
    assert luma.dtype == np.uint16 and 300 < luma.max() <= 1023
