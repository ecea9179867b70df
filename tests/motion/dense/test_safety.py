"""The dense method's do-no-harm steps (``unjello.motion.dense.safety``)."""

from collections import deque

import cv2
import numpy as np

from unjello.motion.dense.safety import (
    BEYOND,
    FOLD_WARNING,
    DenseFrame,
    SafeField,
    _beyond,
    _on_detail,
)


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


def test_folds_count_where_the_picture_shows_detail():
    """A fold over flat sky draws nothing: the share reported is that over detail."""
    rng = np.random.default_rng(0)
    image = np.full((60, 80), 90.0, np.float32) + rng.normal(0, 1.0, (60, 80))  # flat sky
    image[:, 40:] = rng.uniform(0, 255, (60, 40))  # texture on the right
    blobs = np.zeros((60, 80), bool)
    blobs[10:20, 10:20] = True  # over the sky
    assert _on_detail(blobs, image) == 0.0
    blobs[10:20, 50:60] = True  # and as much over the texture
    assert _on_detail(blobs, image) == 0.5
    assert _on_detail(np.zeros_like(blobs), image) == 1.0


def test_a_fast_pan_over_flat_sky_reports_no_fold():
    """The rocket 40 %/0.7 pole clip (``benchmarks/edges.py``): its frame 5's map folds,
    0.27 % of the picture, in the sky around the near pole's slanted trail, where nothing
    shows; it was reported. Over detail it folds nowhere as much."""
    from skimage import data

    from tests.clips import pole_pan
    from unjello.pipeline import correct_frames
    from unjello.timing import SensorTiming

    sim, _ = pole_pan(data.rocket(), 0.4, 0.7)
    _, traj = correct_frames([s.rolling for s in sim], SensorTiming(0.7))
    assert all(f.diagnostics.folds <= FOLD_WARNING for f in traj.frames)


def test_a_near_pole_s_drift_is_not_dropped_for_folds_in_the_sky():
    """The rocket 25 %/1.0 pole clip with ``benchmarks/edges.py --seeds``' noise (seed
    3): frame 6's fitted drifts were all dropped because the map with them folded
    elsewhere -- in the flat sky, where a fold draws nothing -- and the white pole came
    out wavy (15.8 dB). Folds that show decide: the pole keeps its drift (26.0 dB)."""
    from skimage import data

    from tests.clips import pole_pan
    from unjello.metrics import psnr
    from unjello.pipeline import correct_frames
    from unjello.timing import SensorTiming

    sim, _ = pole_pan(data.rocket(), 0.25, 1.0)
    rng = np.random.default_rng(3)
    noisy = [np.clip(np.round(s.rolling + rng.normal(0.0, 0.7, s.rolling.shape)), 0, 255
                     ).astype(np.uint8) for s in sim]
    out, traj = correct_frames(noisy, SensorTiming(1.0))
    assert traj.frames[6].front
    assert psnr(out[6], sim[6].truth, 8) > 22.0
