"""Dense method building blocks (end-to-end accuracy is in tests/test_pipeline.py)."""

import cv2
import numpy as np

from unjello.motion.dense import (
    DenseConfig,
    DenseMethod,
    _advected_velocity,
    invert_flow,
    refine_motion_edges,
    snap_to_global,
    solve_camera_trajectory,
    vibration_level,
)


def test_invert_flow_composes_to_identity():
    # A smooth, non-uniform flow: following it and then its inverse returns home.
    h, w = 60, 80
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    flow = np.stack([3 + 2 * np.sin(yy / 9.0), 1.5 * np.cos(xx / 13.0)], axis=-1)
    inv = invert_flow(flow.astype(np.float32), iterations=8)
    back = cv2.remap(inv, xx + flow[..., 0], yy + flow[..., 1], cv2.INTER_LINEAR)
    inner = (slice(8, -8), slice(8, -8))
    assert np.abs(flow + back)[inner].max() < 0.05


def test_advected_velocity_follows_a_zoom_ahead():
    # A steady zoom (a stationary field v(x) = k (x - centre)): a point at s was at
    # centre + (s - centre) e^{-k} one frame earlier and will be at centre + (s - centre)
    # e^{k/2} half a frame later. A constant velocity per pixel misses the speed-up as
    # the point moves out; carried through the fitted field it must be 5x closer.
    h, w, k = 90, 120, 0.08
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    rel = np.stack([xx - w / 2, yy - h / 2], axis=-1)
    flow = rel * np.float32(np.exp(-k) - 1)  # to the previous frame
    vel = -flow  # mean velocity over that frame
    truth = rel * np.float32(np.exp(k / 2) - 1)
    linear = 0.5 * vel
    ok = np.ones((h, w), bool)
    advected = 0.5 * _advected_velocity(vel, ok, flow, linear)
    inner = (slice(10, -10), slice(10, -10))
    err_lin = np.abs(linear - truth)[inner].mean()
    assert np.abs(advected - truth)[inner].mean() < err_lin / 5


def test_refine_motion_edges_undoes_flow_bleeding():
    # A textured square moved 6 px right over a still textured background; the flow
    # given is the true one blurred across the square's edge (as DIS smooths it). Near
    # the edge the refined flow must be at least 3x closer to the truth.
    rng = np.random.default_rng(1)
    h, w = 96, 128
    prev = cv2.GaussianBlur(rng.random((h, w)).astype(np.float32) * 255, (0, 0), 1.0)
    square = cv2.GaussianBlur(rng.random((h, w)).astype(np.float32) * 255, (0, 0), 1.0)
    inside = np.zeros((h, w), bool)
    inside[30:66, 40:80] = True
    prev = np.where(inside, square, prev).astype(np.float32)
    cur = prev.copy()
    moved = np.roll(inside, 6, axis=1)
    cur[moved] = np.roll(square, 6, axis=1)[moved]
    truth = np.zeros((h, w, 2), np.float32)
    truth[moved, 0] = -6.0  # cur(s) = prev(s + flow)
    given = cv2.GaussianBlur(truth, (0, 0), 4.0)
    near = (cv2.dilate(moved.astype(np.uint8), np.ones((9, 9))) > 0) & ~(
        cv2.erode(moved.astype(np.uint8), np.ones((9, 9))) > 0)
    err_in = np.abs(given - truth)[near].mean()
    err_out = np.abs(refine_motion_edges(cur, prev, given) - truth)[near].mean()
    assert err_out < err_in / 3


def test_snap_to_global_undoes_flow_bleeding_and_keeps_the_object():
    # The background moves by (2.5, -1) px (the camera), a textured square by (-6, 0); the
    # flow given is the truth blurred across the square's edge (as DIS smooths it) plus
    # noise. The background takes the global motion again (at least 5x closer to the
    # truth next to the square, 2x elsewhere, where the noise was all); the square keeps
    # its own flow.
    rng = np.random.default_rng(2)
    h, w = 96, 128
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    background = cv2.GaussianBlur(rng.random((h, w)).astype(np.float32) * 255, (0, 0), 1.0)
    square = cv2.GaussianBlur(rng.random((h, w)).astype(np.float32) * 255, (0, 0), 1.0)
    moved = np.zeros((h, w), bool)
    moved[30:66, 46:86] = True
    truth = np.empty((h, w, 2), np.float32)
    truth[...] = (2.5, -1.0)
    truth[moved] = (-6.0, 0.0)
    other = background.copy()  # the neighbour: cur(s) = other(s + flow(s))
    other[30:66, 40:80] = square[30:66, 40:80]
    cur = cv2.remap(other, xx + truth[..., 0], yy + truth[..., 1], cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_REFLECT)
    given = (cv2.GaussianBlur(truth, (0, 0), 4.0)
             + rng.normal(0, 0.1, truth.shape).astype(np.float32))
    ring = cv2.dilate(moved.astype(np.uint8), np.ones((13, 13))).astype(bool) & ~moved
    far = ~cv2.dilate(moved.astype(np.uint8), np.ones((25, 25))).astype(bool)
    inner = (slice(6, -6), slice(6, -6))
    snapped = snap_to_global(cur, other, given, np.ones((h, w), bool))
    err_in, err_out = (np.linalg.norm(f - truth, axis=-1) for f in (given, snapped))
    assert err_out[inner][ring[inner]].mean() < err_in[inner][ring[inner]].mean() / 5
    assert err_out[inner][far[inner]].mean() < err_in[inner][far[inner]].mean() / 2
    core = cv2.erode(moved.astype(np.uint8), np.ones((9, 9))).astype(bool)
    assert np.array_equal(snapped[core], given[core])


def test_camera_trajectory_follows_a_vibration_within_frames():
    # Per-row equations of a 23 Hz vibration at 30 fps (0.77 cycles per frame): the
    # solved trajectory must follow it at scanline resolution, not smooth it away.
    h, rho = 120, 1.0

    def d(t):
        return 2.0 * np.sin(2 * np.pi * 23 / 30 * t)

    ks = np.repeat(np.arange(1, 8), h)
    y = np.tile(np.arange(h), 7).astype(float)
    ta, tb = ks + rho * y / h, ks - 1 + rho * y / h
    delta = np.stack([d(ta) - d(tb), np.zeros_like(ta)], axis=1)
    sol = solve_camera_trajectory(ta, tb, None, delta, np.ones_like(ta), rho / 32, 1e-6)
    grid = sol.t0 + sol.step * np.arange(len(sol.c))
    t = np.linspace(3, 5, 200)
    est = np.interp(t, grid, sol.c[:, 0])
    est -= est.mean() - d(t).mean()
    assert np.abs(est - d(t)).mean() < 0.2 * np.abs(d(t) - d(t).mean()).mean()


def test_vibration_level_tells_wobble_from_shake_and_layers():
    # Row flows of 10 frame pairs (h = 200 rows, readout one frame), left and right
    # halves: a 23 Hz vibration wobbles whole rows within each frame; a 3 Hz shake does
    # not; a nearer layer sliding through the rows of one half wobbles that half only;
    # a steady per-row pattern (a steady pan's parallax) is not motion at all.
    h = 200
    y = np.arange(h)
    t = np.arange(1, 11)[:, None] + y[None] / h  # frames x rows, in frame intervals
    steady = np.sin(y / 7.0)[None]

    def rows(flow):
        return [(y, np.stack([f, np.zeros(h)], axis=1)) for f in flow]

    def level(d, layer=0.0):
        flow = d(t) - d(t - 1) + steady
        return vibration_level(rows(flow + layer), rows(flow), h)

    jello = level(lambda s: 3 * np.sin(2 * np.pi * 23 / 30 * s))
    shake = level(lambda s: 6 * np.sin(2 * np.pi * 3 / 30 * s))
    sliding = ((y[None] // 20 + np.arange(10)[:, None]) % 3 == 0) * 4.0
    layer = level(lambda s: 5 * s, layer=sliding)
    still = level(lambda s: 0 * s)
    assert jello[0] > 0.004 and jello[1] > 0.5
    assert shake[0] < 0.004 or shake[1] < 0.5
    assert layer[0] < 0.004 and still[0] < 1e-9


def test_a_fade_from_black_is_not_vibration():
    # A pan that fades in from black over 12 frames (sensor noise of 1 grey level): the
    # noise of the first, nearly black frames wobbles like jello (before the contrast
    # gate: "vibration detected", wobble 0.42 %). The same pan without the fade is not
    # vibration either.
    from skimage import data

    from unjello.simulate import Motion, simulate
    from unjello.timing import SensorTiming

    rng = np.random.default_rng(0)
    sim = list(simulate(data.astronaut(), Motion("pan", speed=4.0), SensorTiming(1.0), 24,
                        size=(224, 160)))
    for fade in (12, 1):
        method = DenseMethod(SensorTiming(1.0), DenseConfig())
        out = []
        for k, s in enumerate(sim):
            grey = s.rolling.mean(axis=2) * min(1.0, k / fade)
            out += method.push(np.clip(grey + rng.normal(0, 1.0, grey.shape), 0, 255)
                               .astype(np.uint8), float(k))
        out += method.flush()
        assert len(out) == 24 and "vibration" not in out[0].note, (fade, out[0].note)
