"""Exports and the side outputs of `correct`: STMaps, motion round trip, preview, plots."""

import json

import av
import cv2
import numpy as np
import pytest

from unjello.config import CorrectionConfig
from unjello.exports.outputs import (
    backward_maps,
    maps_to_coded,
    plot_trajectory,
    stmap_image,
)
from unjello.io.frames import read_image, write_image
from unjello.pipeline import correct_frames, correct_video
from unjello.simulate import Motion, simulate
from unjello.timing import DIRECTIONS, SensorTiming
from unjello.trajectory import Trajectory, unpack

from ..clips import make_clip


def _folder(tmp_path, scene, timing, n=4, motion=None):
    src = tmp_path / "in"
    src.mkdir()
    sim = list(simulate(scene, motion or Motion("diagonal", speed=6.0), timing, n,
                        size=(192, 144)))
    for i, s in enumerate(sim):
        write_image(src / f"f{i:03d}.png", s.rolling)
    return src, sim


def stmap_to_maps(stmap):
    """Read an STMap as a compositing app does: R = (x + 0.5) / w, G = 1 - (y + 0.5) / h."""
    h, w = stmap.shape[:2]
    st = stmap[..., :2].astype(np.float64) / 65535.0
    return ((st[..., 0] * w - 0.5).astype(np.float32),
            ((1.0 - st[..., 1]) * h - 0.5).astype(np.float32))


@pytest.mark.parametrize("method", ["paper", "dense"])
@pytest.mark.parametrize("direction", DIRECTIONS)
def test_stmap_reproduces_correction(tmp_path, scene, method, direction):
    timing = SensorTiming(0.8, direction=direction)
    src, sim = _folder(tmp_path, scene, timing)
    out, st = tmp_path / "out", tmp_path / "st"
    correct_video(src, out, CorrectionConfig(method=method, readout=0.8, direction=direction),
                  stmap=st)
    maps = sorted(st.iterdir())
    assert len(maps) == 4
    for i, m in enumerate(maps):
        stm = cv2.imread(str(m), cv2.IMREAD_UNCHANGED)
        assert stm.dtype == np.uint16
        mx, my = stmap_to_maps(cv2.cvtColor(stm, cv2.COLOR_BGR2RGB))
        applied = cv2.remap(sim[i].rolling, mx, my, cv2.INTER_LINEAR,
                            borderMode=cv2.BORDER_REPLICATE)
        ours = read_image(out / f"f{i:03d}.png")
        inner = (slice(8, -8), slice(8, -8))
        assert np.abs(applied[inner].astype(int) - ours[inner]).mean() < 1.0


def test_stmap_encoding_round_trip():
    my, mx = np.mgrid[0:50, 0:80].astype(np.float32)
    mx2, my2 = stmap_to_maps(stmap_image(mx * 0.9 + 0.3, my * 0.9 + 1.2))
    assert np.allclose(mx2, mx * 0.9 + 0.3, atol=0.01)
    assert np.allclose(my2, my * 0.9 + 1.2, atol=0.01)


def test_maps_to_coded_identity_for_zero_motion():
    my, mx = np.mgrid[0:6, 0:9].astype(np.float32)
    for d in DIRECTIONS:
        cx, cy = maps_to_coded(mx, my, d)
        h, w = (6, 9) if d in ("top-bottom", "bottom-top") else (9, 6)
        gy, gx = np.mgrid[0:h, 0:w]
        assert np.allclose(cx, gx) and np.allclose(cy, gy), d


@pytest.mark.parametrize("method", ["paper", "dense"])
def test_motion_out_in_round_trip(tmp_path, scene, method):
    timing = SensorTiming(0.9)
    src, _ = _folder(tmp_path, scene, timing, n=5)
    a, b, motion = tmp_path / "a", tmp_path / "b", tmp_path / "m.json"
    correct_video(src, a, CorrectionConfig(method=method, readout=0.9),
                  motion_out=motion)
    doc = json.loads(motion.read_text())
    assert doc["schema"] == "unjello.trajectory" and doc["version"] == 2
    traj = correct_video(src, b, motion_in=motion)
    assert traj.timing.readout == 0.9
    for f in sorted(a.iterdir()):
        diff = np.abs(read_image(f).astype(int) - read_image(b / f.name)).mean()
        assert diff < 0.5, f.name


def test_preview_video(tmp_path, scene):
    src, dst, prev = tmp_path / "in.mp4", tmp_path / "out.mp4", tmp_path / "prev.mp4"
    make_clip(src, scene, n=5)
    correct_video(src, dst, preview=prev)
    from ..clips import video_pts

    frames = {}
    for name in ("in", "out", "prev"):
        with av.open(str(tmp_path / f"{name}.mp4")) as c:
            frames[name] = [f.to_ndarray(format="rgb24").astype(int) for f in c.decode(video=0)]
    assert len(frames["prev"]) == len(frames["out"]) == 5
    assert video_pts(prev) == video_pts(src)
    w = frames["in"][0].shape[1]
    for a, b, both in zip(frames["in"], frames["out"], frames["prev"], strict=True):
        assert both.shape[1] == 2 * w + 4
        # Left: the input; right: the corrected frame (each up to the preview's encoding).
        assert np.abs(both[:, :w] - a).mean() < 3 and np.abs(both[:, w + 4:] - b).mean() < 3
    assert np.abs(frames["in"][3] - frames["out"][3]).mean() > 5  # and they differ


def test_plot(tmp_path, scene):
    sim = list(simulate(scene, Motion("shake"), SensorTiming(1.0), 6, size=(160, 120)))
    _, traj = correct_frames([s.rolling for s in sim])
    traj.save(tmp_path / "m.json")
    plot_trajectory(Trajectory.load(tmp_path / "m.json"), tmp_path / "m.png")
    img = read_image(tmp_path / "m.png")
    assert img.shape[0] > 300 and img.std() > 10


def test_backward_maps_zero_motion():
    from unjello.trajectory import FrameMotion

    fm = FrameMotion(0, 0.0, np.zeros((10, 2)), np.zeros((10, 2)))
    mx, my = backward_maps(fm, 12)
    assert np.allclose(mx, np.arange(12)[None]) and np.allclose(my, np.arange(10)[:, None])


@pytest.mark.parametrize("grid", [(144, 192), (36, 48), (18, 24)])
def test_a_field_on_a_coarse_grid_is_stored_every_8_frame_pixels(grid):
    """A field on the frame's grid, a working copy's, or one already every 8 px: the JSON
    keeps one sample per 8 frame pixels (not per 8 samples of a coarse grid)."""
    from unjello.trajectory import FrameMotion

    hf, wf = grid
    yy, xx = np.mgrid[0:hf, 0:wf].astype(np.float32)
    field = np.stack([0.05 * xx * 192 / wf, np.sin(yy * 144 / hf / 20)], axis=-1)
    fm = FrameMotion(0, 0.0, np.zeros((144, 2)), np.zeros((144, 2)), field=field)
    d = json.loads(json.dumps(fm.to_dict()))
    assert unpack(d["field"]).shape == (18, 24, 2)
    back = FrameMotion.from_dict(d).field
    assert back.shape == field.shape
    assert np.abs(back - field)[2:-2, 2:-2].max() < 0.15
