"""A clip's settings decided once (unjello.clip): each file read once, as correct uses them."""

import json

import unjello.clip as clip_module
from tests.clips import make_clip
from unjello.config import CorrectionConfig
from unjello.pipeline import correct_video


def test_the_lens_profile_is_read_once_per_run(tmp_path, scene, monkeypatch):
    src = tmp_path / "clip.mp4"
    make_clip(src, scene, n=4, size=(160, 120))
    profile = tmp_path / "lens.json"
    profile.write_text(json.dumps({
        "name": "test lens", "frame_readout_time": 20.0,
        "calib_dimension": {"w": 160, "h": 120}, "fisheye_params": {
            "camera_matrix": [[150, 0, 80], [0, 150, 60], [0, 0, 1]],
            "distortion_coeffs": [0.05, 0.0, 0.0, 0.0]}}))
    reads = []
    real = clip_module.read_lens_profile

    def counting(path):
        reads.append(path)
        return real(path)

    monkeypatch.setattr(clip_module, "read_lens_profile", counting)
    messages = []
    traj = correct_video(src, tmp_path / "out.mp4",
                         CorrectionConfig(lens_profile=str(profile), undistort=True),
                         log=messages.append)
    assert len(reads) == 1
    assert abs(traj.timing.readout - 0.6) < 1e-9  # its 20 ms at 30 fps
    assert any("lens from the lens profile" in m for m in messages)  # and its lens
