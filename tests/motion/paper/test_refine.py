import cv2
import numpy as np

from unjello.motion.paper.refine import (
    LocalMatches,
    RefineConfig,
    better_matches,
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


def _matches(rows_of_blocks, accepted):
    centers = np.array([[8 + 16 * i, 8 + 16 * r] for r, n in rows_of_blocks for i in range(n)],
                       dtype=float)
    n = len(centers)
    return LocalMatches(centers, np.zeros((n, 2)), np.zeros(n), np.asarray(accepted, bool))


def test_row_samples_keep_each_block_row_apart():
    """Centres at 8 + 16 k: rounding to even merged block rows 0 and 1, 2 and 3, ..."""
    m = _matches([(0, 4), (1, 4), (2, 4), (3, 4)], [True] * 16)
    v = np.repeat([[1.0, 0], [2, 0], [3, 0], [4, 0]], 4, axis=0)
    t, vs = row_samples(m, v, m.centers[:, 1] / 100.0, 16, 3)
    assert t.size == 4 and vs[:, 0].tolist() == [1.0, 2.0, 3.0, 4.0]


def test_a_few_false_matches_do_not_make_a_sample():
    """Of 40 blocks tested in a row, 4 accepted (the right ones rejected at the window's
    edge) is not a sample; 20 is."""
    m = _matches([(0, 40), (1, 40)], [True] * 4 + [False] * 36 + [True] * 20 + [False] * 20)
    t, vs = row_samples(m, np.ones((80, 2)), np.arange(80) / 100.0, 16, 3)
    assert t.size == 1 and abs(t[0] - np.median(np.arange(40, 60)) / 100.0) < 1e-9


def test_a_row_sample_is_its_blocks_histogram_peak():
    """Sec. V.C's local motion is found "in a way similar to global motion estimation":
    the blocks at the peak of the row's vector histogram make the sample. Half of them
    scattered over other motions is not an agreement, however many were accepted."""
    m = _matches([(0, 10), (1, 10)], [True] * 20)
    motion = np.zeros((20, 2))
    motion[:10] = [[5.0, 0.0]] * 6 + [[9.0, 2.0], [12.0, -3.0], [-4.0, 1.0], [0.0, 7.0]]
    motion[10:] = [[5.0, 0.0]] * 4 + [[9.0, 2.0], [12.0, -3.0], [-4.0, 1.0], [0.0, 7.0],
                                      [20.0, 0.0], [-9.0, -9.0]]
    m = LocalMatches(m.centers, motion, m.residual, m.accepted)
    t, vs = row_samples(m, motion, m.centers[:, 1] / 100.0, 16, 3)
    # Row 0: 6 of 10 agree on (5, 0) and the sample is theirs; row 1: 4 of 10 agree (all
    # ten were accepted, which was enough before): no sample.
    assert t.size == 1 and vs.tolist() == [[5.0, 0.0]]


def test_the_better_of_two_windows_is_kept(scene):
    """A prediction 12 px off puts the true match outside its window; the window around
    g(n) holds it, and the better residual wins block by block."""
    g = cv2.cvtColor(scene, cv2.COLOR_RGB2GRAY).astype(np.float32)
    prev, cur = g[100:260, 100:300], g[100:260, 112:312]  # l = (-12, 0)
    ys, xs = np.mgrid[40:120:16, 40:160:16]
    centers = np.stack([xs.ravel(), ys.ravel()], axis=1).astype(float)
    cfg = RefineConfig(radius=4)
    wrong = local_block_match(prev, cur, centers, np.zeros((len(centers), 2)), cfg)
    around_g = local_block_match(prev, cur, centers, np.tile([-11.0, 0.0], (len(centers), 1)),
                                 cfg)
    best = better_matches(wrong, around_g)
    assert best.accepted.mean() > 0.5
    assert np.allclose(best.motion[best.accepted], [-12.0, 0.0], atol=0.2)
    assert better_matches(around_g, wrong).accepted.tolist() == best.accepted.tolist()
