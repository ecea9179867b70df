import numpy as np
import pytest

from unjello.config import CorrectionConfig
from unjello.errors import InputError
from unjello.io.frames import list_frames, read_image, write_image
from unjello.pipeline import correct_video
from unjello.simulate import Motion, simulate
from unjello.timing import SensorTiming


def test_two_frame_folder_in_two_frame_folder_out(tmp_path, scene):
    src = tmp_path / "pair"
    src.mkdir()
    sim = list(simulate(scene, Motion("pan", speed=8.0), SensorTiming(1.0), 2, size=(192, 144)))
    for name, s in zip(["rs_0.png", "rs_1.png"], sim, strict=True):
        write_image(src / name, s.rolling)
    dst = tmp_path / "out"
    traj = correct_video(src, dst, CorrectionConfig(readout=1.0))
    assert sorted(p.name for p in dst.iterdir()) == ["rs_0.png", "rs_1.png"]
    assert len(traj) == 2
    err = np.abs(traj.frames[1].displacement - sim[1].motion.displacement).mean()
    assert err < 0.1
    out = read_image(dst / "rs_1.png")
    assert out.shape == sim[1].rolling.shape and out.dtype == np.uint8


def test_rgba_round_trip(tmp_path):
    img = np.random.default_rng(0).integers(0, 255, (20, 30, 4), dtype=np.uint8)
    write_image(tmp_path / "a.png", img)
    assert np.array_equal(read_image(tmp_path / "a.png"), img)


def test_empty_folder(tmp_path):
    with pytest.raises(InputError, match="no images"):
        list_frames(tmp_path)


def test_mixed_sizes(tmp_path):
    write_image(tmp_path / "a.png", np.zeros((32, 32, 3), np.uint8))
    write_image(tmp_path / "b.png", np.zeros((40, 32, 3), np.uint8))
    with pytest.raises(InputError, match="differs"):
        correct_video(tmp_path, tmp_path.parent / "out_mixed")


def test_frames_are_listed_in_natural_order(tmp_path):
    """Unpadded numbers (frame-99, frame-100) keep the clip's order, not the string order."""
    img = np.zeros((4, 4, 3), np.uint8)
    for n in (100, 9, 99, 101, 10):
        write_image(tmp_path / f"frame-{n}.png", img)
    assert [p.stem for p in list_frames(tmp_path)] == [
        "frame-9", "frame-10", "frame-99", "frame-100", "frame-101"]
