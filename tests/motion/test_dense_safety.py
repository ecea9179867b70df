"""The dense method's do-no-harm steps (``unjello.motion.dense_safety``)."""

from collections import deque

import cv2
import numpy as np

from unjello.motion.dense_safety import BEYOND, DenseFrame, SafeField, _beyond


def test_a_side_whose_flow_leaves_the_frame_does_not_vouch_for_a_pixel():
    """An object leaving the frame is seen by one neighbour: where that neighbour's flow
    carries it onto unlike grey levels, it is missed, though the other side's flow lands
    outside (before: not missed, and a near pole the flow lost kept the background's
    motion). A flow landing just outside (within BEYOND px) still counts as a side."""
    rng = np.random.default_rng(0)
    h, w = 60, 80
    scene = cv2.GaussianBlur(rng.uniform(0, 255, (h, w + 40)).astype(np.float32), (0, 0), 1.5)
    prev, cur, nxt = scene[:, :w], scene[:, 10:w + 10].copy(), scene[:, 20:w + 20]
    cur[20:40, 2:16] = 255.0 - cur[20:40, 2:16]  # an object at the left side, leaving
    bwd = np.zeros((h, w, 2), np.float32)
    bwd[..., 0] = 10.0  # cur(s) = prev(s + 10): right for the scene, wrong for the object
    fwd = np.zeros((h, w, 2), np.float32)
    fwd[..., 0] = -40.0  # the object lands far beyond the left edge in the next frame
    frames = [DenseFrame(0, 0.0, prev), DenseFrame(1, 1.0, cur, bwd=bwd, fwd=fwd),
              DenseFrame(2, 2.0, nxt)]

    class Method(SafeField):
        _frames = deque(frames)

    missed = Method()._missed(frames[1])
    assert missed[24:36, 5:13].mean() > 0.8  # the previous frame misses it; the next cannot say
    assert not missed[:, 30:].any()  # the scene: the previous frame matches it
    flow = np.zeros((1, 4, 2), np.float32)
    flow[0, :, 0] = [-BEYOND / 2, -2 * BEYOND, 0.0, BEYOND / 2]
    assert _beyond(flow)[0].tolist() == [False, True, False, False]
