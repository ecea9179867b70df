"""A flow's inverse (:mod:`unjello.motion.flow.inverse`)."""

import cv2
import numpy as np
import pytest

from unjello.motion.flow.inverse import invert_flow, row_modes


def test_invert_flow_composes_to_identity():
    # A smooth, non-uniform flow: following it and then its inverse returns home.
    h, w = 60, 80
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    flow = np.stack([3 + 2 * np.sin(yy / 9.0), 1.5 * np.cos(xx / 13.0)], axis=-1)
    inv = invert_flow(flow.astype(np.float32), iterations=8)
    back = cv2.remap(inv, xx + flow[..., 0], yy + flow[..., 1], cv2.INTER_LINEAR)
    inner = (slice(8, -8), slice(8, -8))
    assert np.abs(flow + back)[inner].max() < 0.05


def test_an_inverted_flow_at_the_sides_takes_the_fixed_point_the_images_agree_with():
    """Issue 38: in a fast pan, the other frame's side shows what entered it; its flow
    there is a guess, and inverting from it settles on that guess (a second fixed
    point, landing inside). The images tell the two apart."""
    rng = np.random.default_rng(3)
    scene = cv2.GaussianBlur(rng.uniform(0, 255, (40, 140)).astype(np.float32), (0, 0), 1.5)
    a, b = scene[:, 40:120].copy(), scene[:, 20:100].copy()  # b(s) = a(s - 20)
    flow = np.zeros((40, 80, 2), np.float32)
    flow[..., 0] = -20.0
    flow[:, :20, 0] = 6.0  # b's first 20 columns entered: a guess that lands inside a
    plain = invert_flow(flow)
    assert not np.allclose(plain[:, 10:14, 0], 20.0)  # the guess's fixed point
    fixed = invert_flow(flow, images=(a, b))
    assert np.allclose(fixed[:, :40, 0], 20.0, atol=0.01)  # a(q) = b(q + 20)
    assert np.allclose(fixed[:, 60:, 0], plain[:, 60:, 0])


@pytest.mark.parametrize("h", [30, 540])
def test_row_modes_is_the_rows_matched_motion_where_most_of_it_entered(h):
    """A pan of 60 % of the width a frame: the other frame's left 60 % entered it, its
    flow a guess spread over -60..+40 px; the matched 40 % moves -192. The median of the
    middle half was the guess's; the mode is the pan's (540 rows: every 4th measured)."""
    rng = np.random.default_rng(1)
    flow = np.zeros((h, 320, 2), np.float32)
    flow[..., 0] = -192.0 + rng.normal(0.0, 0.3, (h, 320))
    flow[:, :192, 0] = rng.uniform(-60.0, 40.0, (h, 192))
    flow[..., 1] = rng.normal(0.0, 0.3, (h, 320))
    assert abs(float(np.median(flow[:, 80:240, 0])) + 192.0) > 100.0  # the old dominant
    modes = row_modes(flow)
    assert np.abs(modes[:, 0] + 192.0).max() < 0.5 and np.abs(modes[:, 1]).max() < 0.5


def test_an_inverted_flow_where_most_of_the_other_frame_entered_it():
    """The same pan: ``a``'s right side lies 192 px back in ``b``, where ``b``'s flow is
    the pan's; the guesses on what entered ``b`` gave a second fixed point inside. The
    sides are restarted as far in as a quarter of the width (the strip beyond the edge
    is read a few pixels in)."""
    rng = np.random.default_rng(2)
    scene = cv2.GaussianBlur(rng.uniform(0, 255, (40, 520)).astype(np.float32), (0, 0), 1.5)
    a, b = scene[:, 0:320].copy(), scene[:, 192:512].copy()  # b(s) = a(s + 192)
    flow = np.zeros((40, 320, 2), np.float32)
    flow[..., 0] = 192.0
    flow[:, 128:, 0] = rng.uniform(-20.0, 20.0, (40, 192))  # b's right 60 %: entered
    inv = invert_flow(flow, images=(a, b))
    assert np.allclose(inv[:, 240:, 0], -192.0, atol=0.01)  # a(q) = b(q - 192)
