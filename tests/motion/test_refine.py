import cv2
import numpy as np

from unjello.motion.refine import (
    RefineConfig,
    inside_constraints,
    local_block_match,
    predict_local_motion,
    refined_velocity,
    row_samples,
)


def test_eq25_inverts_prediction():
    v = np.array([[3.0, -4.0], [0.5, 12.0], [-7.0, 0.0]])
    lm = predict_local_motion(v, 1.0, 0.8, 240)
    assert np.allclose(refined_velocity(lm, 1.0, 0.8, 240), v)


def test_constraints_eq22_23():
    centers = np.array([[10.0, 10.0], [100.0, 50.0], [190.0, 90.0]])
    motion = np.array([[15.0, 0.0], [5.0, 5.0], [0.0, -20.0]])
    ok = inside_constraints(centers, motion, (200, 100), (8.0, 8.0))
    assert ok.tolist() == [False, True, False]


def test_local_block_match_finds_shift(scene):
    g = cv2.cvtColor(scene, cv2.COLOR_RGB2GRAY).astype(np.float32)
    prev = g[100:260, 100:300]
    cur = g[100 - 3:260 - 3, 100 + 5:300 + 5]  # l = (-5, +3)
    ys, xs = np.mgrid[40:120:16, 40:160:16]
    centers = np.stack([xs.ravel(), ys.ravel()], axis=1).astype(float)
    pred = np.tile([-3.0, 1.0], (len(centers), 1))
    lm = local_block_match(prev, cur, centers, pred, RefineConfig(radius=4))
    assert lm.accepted.mean() > 0.5
    # Whole-pixel shift: every block within a fifth of a pixel, the median exact.
    assert np.allclose(lm.motion[lm.accepted], [-5.0, 3.0], atol=0.2)
    assert np.allclose(np.median(lm.motion[lm.accepted], axis=0), [-5.0, 3.0], atol=0.02)
    t, v = row_samples(lm, lm.motion, centers[:, 1], 16, 3)
    assert len(t) >= 3 and np.allclose(v, [-5.0, 3.0], atol=0.05)


def test_window_edge_is_rejected(scene):
    g = cv2.cvtColor(scene, cv2.COLOR_RGB2GRAY).astype(np.float32)
    prev, cur = g[100:260, 100:300], g[100:260, 112:312]  # l = (-12, 0)
    centers = np.array([[100.0, 80.0]])
    lm = local_block_match(prev, cur, centers, np.array([[0.0, 0.0]]), RefineConfig(radius=4))
    assert not lm.accepted[0]
