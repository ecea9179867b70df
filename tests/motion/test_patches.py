"""Flows scored over patches: one patch mean of the difference picks as two patch means do."""

import cv2
import numpy as np

from unjello.motion.patches import costlier, map_cost
from unjello.timing import pixel_grid


def test_costlier_picks_as_two_patch_costs_compared():
    rng = np.random.default_rng(3)
    h, w = 54, 96
    other = cv2.GaussianBlur(rng.uniform(0, 255, (h, w)).astype(np.float32), (0, 0), 1.5)
    cur = np.roll(other, -2, axis=1)  # cur(s) = other(s + (2, 0))
    gx, gy = pixel_grid(h, w)
    right = (gx + np.float32(2.0), gy)
    wrong = (gx + rng.normal(2.0, 1.5, (h, w)).astype(np.float32), gy.copy())
    want = cv2.compare(map_cost(cur, other, *wrong, 9), map_cost(cur, other, *right, 9),
                       cv2.CMP_GT)
    got = costlier(cur, other, wrong, right, 9)
    assert got.dtype == np.uint8 and got.shape == (h, w)
    assert np.array_equal(got, want)
    assert got[:, 10:-10].mean() > 200  # the noisy maps cost more nearly everywhere
    assert not costlier(cur, other, right, right, 9).any()  # a tie is not costlier
