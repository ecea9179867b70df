import cv2
import numpy as np
import pytest

from unjello.motion.paper.global_motion import (
    BlockMatchConfig,
    block_match,
    global_motion,
    histogram_peak,
)

from ..bruteforce import brute_force_vectors


def _gray(img):
    return cv2.cvtColor(img, cv2.COLOR_RGB2GRAY).astype(np.float32)


@pytest.mark.parametrize("search, hint", [(8, (0, 0)), (20, (5, -3)), (20, (-40, 17))])
def test_equals_exhaustive_search(scene, search, hint):
    g = _gray(scene)
    prev = g[100:228, 60:220]
    cur = g[97:225, 66:226]  # content moves by (-6, +3)
    bv = block_match(prev, cur, BlockMatchConfig(search=search), hint=hint)
    bf = brute_force_vectors(prev, cur, 16, search, 2.0)
    assert bv.vectors.shape == bf.shape
    assert np.array_equal(bv.vectors, bf)


def test_equals_exhaustive_search_full_range():
    # The paper's +/-160 px range on a small noisy frame (window clipped by the frame).
    rng = np.random.default_rng(3)
    base = cv2.GaussianBlur(rng.uniform(0, 255, (120, 200)).astype(np.float32), (0, 0), 1.5)
    prev, cur = base[:96, :160], base[4:100, 9:169]
    bv = block_match(prev, cur, BlockMatchConfig(search=160))
    assert np.array_equal(bv.vectors, brute_force_vectors(prev, cur, 16, 160, 2.0))


@pytest.mark.parametrize("shift", [(12, -7), (-3, 0), (0, 25)])
def test_integer_shift(scene, shift):
    g = _gray(scene)
    dx, dy = shift
    prev = g[150:342, 150:406]
    cur = g[150 - dy:342 - dy, 150 - dx:406 - dx]
    gm = global_motion(prev, cur)
    assert gm.ok
    assert gm.peak.tolist() == [dx, dy]
    assert np.allclose(gm.vector, shift, atol=0.05)


@pytest.mark.parametrize("shift", [(2.5, 0.0), (-4.3, 1.7), (0.25, -6.6)])
def test_fractional_shift(scene, shift):
    g = cv2.GaussianBlur(_gray(scene), (0, 0), 1.0)
    m = np.float32([[1, 0, shift[0]], [0, 1, shift[1]]])
    moved = cv2.warpAffine(g, m, g.shape[::-1], flags=cv2.INTER_CUBIC)
    prev, cur = g[100:400, 100:400], moved[100:400, 100:400]
    gm = global_motion(prev, cur, BlockMatchConfig(search=32))
    assert np.allclose(gm.vector, shift, atol=0.15)


def test_histogram_peak_with_outliers():
    rng = np.random.default_rng(0)
    good = np.tile([5, -2], (70, 1)) + rng.integers(-1, 2, (70, 2)) * (rng.random((70, 1)) < 0.2)
    bad = rng.integers(-30, 31, (30, 2))
    peak, hist = histogram_peak(np.vstack([good, bad]), 32, sigma=1.0)
    assert peak.tolist() == [5, -2]
    assert hist.shape == (65, 65)


def test_textureless_frame_fails_cleanly():
    flat = np.full((64, 64), 128, np.float32)
    gm = global_motion(flat, flat)
    assert not gm
    assert gm.vector.tolist() == [0.0, 0.0]
