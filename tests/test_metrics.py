"""Metrics against ground truth: PSNR/SSIM as skimage computes them, displacement error."""

import numpy as np
import pytest
from skimage.metrics import peak_signal_noise_ratio, structural_similarity

from unjello.errors import InputError
from unjello.io.frames import write_image
from unjello.metrics import crop_margin, displacement_error, evaluate, psnr, ssim
from unjello.timing import SensorTiming
from unjello.trajectory import FrameMotion, Trajectory


def test_psnr_and_ssim_match_scikit_image_and_crop_the_margin():
    rng = np.random.default_rng(0)
    truth = rng.integers(0, 256, (40, 60, 3), dtype=np.uint8)
    noisy = np.clip(truth + rng.normal(0, 8, truth.shape), 0, 255).astype(np.uint8)
    assert psnr(noisy, truth) == pytest.approx(peak_signal_noise_ratio(truth, noisy))
    assert psnr(truth, truth) == 100.0
    framed = noisy.copy()
    framed[:5] = 0  # a ruined border, cropped away
    assert psnr(framed, truth, 5) == pytest.approx(
        peak_signal_noise_ratio(truth[5:-5, 5:-5], noisy[5:-5, 5:-5]))
    assert crop_margin(truth, (2, 3)).shape == (34, 56, 3)
    assert ssim(truth, truth) == pytest.approx(1.0)
    assert ssim(noisy, truth) == pytest.approx(structural_similarity(
        truth, noisy, data_range=255, channel_axis=-1)) and ssim(noisy, truth) < 1.0
    # 16-bit images use their own range.
    assert psnr(truth.astype(np.uint16) * 257, truth.astype(np.uint16) * 257) == 100.0


def test_displacement_error_per_scanline_and_per_pixel():
    h, w = 10, 16
    truth = FrameMotion(0, 0.0, np.tile([3.0, 4.0], (h, 1)), np.zeros((h, 2)))
    assert displacement_error(None, truth) == pytest.approx(5.0)
    est = FrameMotion(0, 0.0, np.tile([3.0, 0.0], (h, 1)), np.zeros((h, 2)))
    assert displacement_error(est, truth) == pytest.approx(4.0)
    # A per-pixel truth (a layer moving 2 px more on the right half), scored per pixel.
    fld = np.broadcast_to(truth.displacement[:, None], (h, w, 2)).copy()
    fld[:, w // 2:, 0] += 2.0
    layered = FrameMotion(0, 0.0, truth.displacement, truth.velocity, field=fld)
    assert displacement_error(FrameMotion(0, 0.0, truth.displacement, truth.velocity),
                              layered) == pytest.approx(1.0)
    left = np.zeros((h, w), bool)
    left[:, : w // 2] = True
    assert displacement_error(FrameMotion(0, 0.0, truth.displacement, truth.velocity),
                              layered, mask=left) == pytest.approx(0.0)


def test_evaluate_scores_each_frame_against_its_truth(tmp_path):
    rng = np.random.default_rng(1)
    out, gs = tmp_path / "out", tmp_path / "gs"
    out.mkdir()
    gs.mkdir()
    h = 32
    traj = Trajectory(SensorTiming(1.0), (48, h), method="truth")
    for i in range(3):
        img = rng.integers(0, 256, (h, 48, 3), dtype=np.uint8)
        write_image(gs / f"f{i}.png", img)
        write_image(out / f"f{i}.png", img if i else np.clip(img.astype(int) + 4, 0, 255)
                    .astype(np.uint8))
        traj.frames.append(FrameMotion(i, float(i), np.tile([1.0, 0.0], (h, 1)),
                                       np.zeros((h, 2))))
    traj.save(tmp_path / "gs.motion.json")
    (tmp_path / "gs.motion.json").rename(f"{gs}.motion.json")
    traj.save(tmp_path / "est.json")
    rows = evaluate(out, gs, motion=tmp_path / "est.json")
    assert [r["frame"] for r in rows] == [0, 1, 2]
    assert rows[0]["psnr"] < 40 and rows[1]["psnr"] == 100.0
    assert rows[2]["uncorrected_error"] == pytest.approx(1.0)
    assert rows[2]["displacement_error"] == pytest.approx(0.0)
    small = tmp_path / "small"
    small.mkdir()
    write_image(small / "f0.png", np.zeros((16, 16, 3), np.uint8))
    with pytest.raises(InputError, match="differ in size"):
        evaluate(small, gs)
