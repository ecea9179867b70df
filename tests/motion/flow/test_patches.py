"""Flows scored over patches: one patch mean of the difference picks as two patch means do."""

import cv2
import numpy as np

from unjello.motion.flow.patches import costlier, map_cost, unmatched_entering
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


def test_where_content_enters_only_confirmed_flows_are_kept():
    # cur(s) = other(s + t), t = (-20, -12): cur's top 12 rows and left 20 columns entered
    # the frame (new texture, and a flat wall); a near object there moves on its own and
    # is in ``other`` (its flow matches). Wrong flows landing inside on the new content
    # and on the wall are not confirmed; the object's and the rest of the frame's are.
    rng = np.random.default_rng(5)
    h, w = 120, 200
    other = cv2.GaussianBlur(rng.uniform(0, 255, (h, w)).astype(np.float32), (0, 0), 2.0)
    t = np.array([-20.0, -12.0], np.float32)
    gx, gy = pixel_grid(h, w)
    cur = cv2.remap(other, gx + t[0], gy + t[1], cv2.INTER_LINEAR)
    new = cv2.GaussianBlur(rng.uniform(0, 255, (h, w)).astype(np.float32), (0, 0), 2.0)
    band = (gx + t[0] < 0) | (gy + t[1] < 0)
    cur[band] = new[band]
    cur[:12, 100:] = 90.0  # a flat wall entering at the top
    flow = np.empty((h, w, 2), np.float32)
    flow[...] = t
    flow[band] = (0.0, 0.0)  # DIS's guesses there: land inside on whatever looked alike
    obj = (slice(40, 80), slice(0, 20))  # in the band: moves (+30, 0) px on its own
    cur[obj] = cv2.remap(other, gx + 30, gy, cv2.INTER_LINEAR)[obj]
    flow[obj] = (30.0, 0.0)
    flagged = unmatched_entering(cur, other, flow, t, 15)
    inner = np.zeros((h, w), bool)
    inner[:5, 30:95] = inner[:5, 110:190] = inner[20:32, :10] = inner[90:, :10] = True
    assert flagged[inner & band].all()  # the new texture and the wall, away from edges
    assert not flagged[~band].any()
    assert not flagged[48:72, 4:12].any()  # the object's own motion is confirmed
    # A translation the flow does not share (a phase correlation's alias): nothing.
    assert not unmatched_entering(cur, other, flow, np.float32([25.0, 15.0]), 15).any()
