"""Dense method building blocks (end to end: tests/motion/dense/test_quality.py)."""

from concurrent.futures import Executor, Future

import cv2
import numpy as np
import pytest

from unjello.motion.dense.field import advected_velocity, snap_to_global
from unjello.motion.dense.method import DenseConfig, DenseMethod


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
    advected = 0.5 * advected_velocity(vel, ok, flow, linear)
    inner = (slice(10, -10), slice(10, -10))
    err_lin = np.abs(linear - truth)[inner].mean()
    assert np.abs(advected - truth)[inner].mean() < err_lin / 5


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


def test_content_entering_the_frame_is_told_apart_from_failed_flow(scene):
    """A pan brings new content in at one edge: no flow can match it, and it is reported
    as entering the frame, not as unreliable flow."""
    from unjello.simulate import Motion, simulate
    from unjello.timing import SensorTiming

    w, speed = 224, 16.0
    sim = list(simulate(scene, Motion("pan", speed=speed), SensorTiming(1.0), 4, size=(w, 160)))
    method = DenseMethod(SensorTiming(1.0), DenseConfig())
    out = []
    for k, s in enumerate(sim):
        out += method.push(s.rolling.mean(axis=2).astype(np.uint8), float(k))
    out += method.flush()
    # The first and last frames see one neighbour: a band of about the pan's width enters.
    for fm in (out[0], out[-1]):
        assert 0.5 * speed / w < fm.diagnostics.entering <= fm.diagnostics.fallback
        assert fm.diagnostics.entering < 2.0 * speed / w
    # The middle frames see both neighbours: what one misses, the other saw.
    assert all(fm.diagnostics.entering < 0.01 for fm in out[1:-1])


def test_flows_measured_ahead_on_threads_give_the_same_motion(scene):
    """With an executor the next pairs' flows are measured while earlier frames are
    solved: every frame's motion is the same, bit for bit, in the same order, with the
    per-pixel field and in the rows-only mode."""
    from concurrent.futures import ThreadPoolExecutor

    from unjello.simulate import Motion, simulate
    from unjello.timing import SensorTiming

    sim = list(simulate(scene, Motion("shake", amplitude=3.0), SensorTiming(0.9), 9,
                        size=(192, 128)))
    grey = [s.rolling.mean(axis=2).astype(np.uint8) for s in sim]
    for config in (DenseConfig(), DenseConfig(per_pixel=False)):
        runs = []
        for pool in (None, ThreadPoolExecutor(3)):
            method = DenseMethod(SensorTiming(0.9), config, executor=pool, ahead=3)
            out = []
            for k, g in enumerate(grey):
                out += method.push(g, float(k))
            out += method.flush()
            runs.append(out)
        plain, ahead = runs
        assert [fm.index for fm in ahead] == list(range(len(grey)))
        for a, b in zip(plain, ahead, strict=True):
            assert np.array_equal(a.displacement, b.displacement)
            assert a.note == b.note
            if config.per_pixel:
                assert np.array_equal(a.field, b.field)


class _Late(Future):
    done_now = False

    def done(self):
        return self.done_now


class _Batches(Executor):
    """Runs each job at once, but says it is done only once 3 are queued (a busy machine)."""

    def __init__(self):
        self.queued = []

    def submit(self, fn, /, *args, **kwargs):
        job = _Late()
        job.set_result(fn(*args, **kwargs))
        self.queued.append(job)
        if len(self.queued) >= 3:
            for j in self.queued:
                j.done_now = True
            self.queued = []
        return job


def test_the_model_choice_does_not_depend_on_how_many_flows_were_done(scene):
    """Flows an executor finishes several at a time (as on a busy machine) give the same
    choice of camera model, from the same pairs, and the same motion, as flows measured
    one after another: taken all at once, the choice saw 9 pairs instead of 8."""
    from unjello.simulate import Motion, simulate
    from unjello.timing import SensorTiming

    sim = list(simulate(scene, Motion("jello"), SensorTiming(1.0), 14, size=(192, 128)))
    grey = [s.rolling.mean(axis=2).astype(np.uint8) for s in sim]
    runs = []
    for pool in (None, _Batches()):
        method = DenseMethod(SensorTiming(1.0), DenseConfig(), executor=pool, ahead=6)
        out = []
        for k, g in enumerate(grey):
            out += method.push(g, float(k))
        out += method.flush()
        runs.append((out, method.decisions))
    (plain, chosen), (batched, chosen_batched) = runs
    assert chosen == chosen_batched and chosen[0][2]["pairs"] == DenseConfig().probe
    assert [fm.index for fm in batched] == list(range(len(grey)))
    for a, b in zip(plain, batched, strict=True):
        assert np.array_equal(a.displacement, b.displacement)
        assert np.array_equal(a.field, b.field)


def test_full_flows_after_a_spinner_do_not_depend_on_how_far_ahead_they_started(scene):
    """Once an object spins, the next pairs' flows are the full ones. Flows started ahead
    with the polished settings are measured again, so the motion is the same whether they
    were done at once or late: before, frame 9 here was turned back only when they were
    done at once (and TUM's sequence 4 differed in four frames run to run)."""
    from skimage import data

    from unjello.simulate import Motion, simulate
    from unjello.timing import SensorTiming

    sim = list(simulate(scene, Motion("pan", speed=5.0), SensorTiming(1.0), 16,
                        size=(192, 128), layers="propeller", layer_image=data.coffee()))
    grey = [s.rolling.mean(axis=2).astype(np.uint8) for s in sim]
    runs = []
    for pool in (None, _Batches()):
        method = DenseMethod(SensorTiming(1.0), DenseConfig(detail="polished"),
                             executor=pool, ahead=6)
        out = []
        for k, g in enumerate(grey):
            out += method.push(g, float(k))
        runs.append(out + method.flush())
    plain, batched = runs
    assert any(f.diagnostics.spun > 0 or f.diagnostics.kept > 0 for f in plain)
    for a, b in zip(plain, batched, strict=True):
        assert np.array_equal(a.field, b.field)


@pytest.mark.parametrize("polish", [1, 0])
def test_a_vibrating_clip_has_its_probed_pairs_measured_again_in_full(scene, monkeypatch,
                                                                      polish):
    """The polished flows the vibration probe looked at are measured again at full detail
    once the clip is found to vibrate (under the vibration model they cost the simulated
    drone jello 0.06x), and every later pair is measured in full at once; also with no
    polishing iteration (the half-resolution flow alone: it went unmeasured, 0.63 ->
    0.71x)."""
    import unjello.motion.dense.config as dense_config
    import unjello.motion.dense.method as dense
    from unjello.simulate import Motion, simulate
    from unjello.timing import SensorTiming

    monkeypatch.setitem(dense_config.POLISHED, "polish", polish)
    calls = []

    def spy(prev, cur, settings, *args, **kwargs):
        # 1 for the polished flow (DIS to half resolution), 0 for the full one
        calls.append((hash(np.asarray(cur).tobytes()), int(settings.finest_scale == 1)))
        return dense.flow_pair.__wrapped__(prev, cur, settings, *args, **kwargs)

    spy.__wrapped__ = dense.flow_pair
    monkeypatch.setattr(dense, "flow_pair", spy)
    sim = list(simulate(scene, Motion("jello"), SensorTiming(1.0), 12, size=(320, 240)))
    method = DenseMethod(SensorTiming(1.0), DenseConfig())
    out = []
    for k, s in enumerate(sim):
        out += method.push(s.rolling.mean(axis=2).astype(np.uint8), float(k))
    out += method.flush()
    assert method.vibrating and len(out) == 12
    last = {}
    for pair, polish in calls:
        last[pair] = polish
    assert len(last) == 11 and set(last.values()) == {0}  # each pair's last flow: full
    assert 0 < sum(p for _, p in calls) and len(calls) < 2 * 11


def test_content_entering_a_pair_moves_with_its_row():
    """A pair cannot tell the camera's trajectory from its rows' velocity: both count.

    At 40 % of the width a frame, the frame's left 40 % is content the previous frame
    did not show (no flow lands inside): it is on the camera model, which must carry the
    row velocity's part too (it carried the trajectory's alone: 0.41x the displacement).
    """
    from skimage import data

    from unjello.pipeline import correct_frames
    from unjello.simulate import Motion, simulate
    from unjello.timing import SensorTiming

    timing = SensorTiming(0.7)
    sim = list(simulate(data.astronaut(), Motion("pan", speed=128.0), timing, 2,
                        size=(320, 180)))
    _, traj = correct_frames([s.rolling for s in sim], timing)
    est = traj.frames[1].pixel_displacement(320)[:, :24, 0]
    true = sim[1].motion.pixel_displacement(320)[:, :24, 0]
    assert np.median(np.abs(est - true)) < 0.5
    assert np.median(np.abs(true)) > 15  # a case where it shows


def test_a_fast_diagonal_pan_is_followed_in_the_rows_that_entered():
    """A pan of 64 x 38 px a frame (320 x 180, readout 0.4): the top fifth of each frame
    entered it. The first pair's flow there landed inside on whatever looked alike and
    passed its own check; no equation reached those rows, whose camera stood still.
    Error against the uncorrected, before: the pair 0.045 / 0.214, a 4-frame clip's last
    frame 0.232.
    """
    from skimage import data

    from unjello.metrics import displacement_error
    from unjello.pipeline import correct_frames
    from unjello.simulate import Motion, simulate
    from unjello.timing import SensorTiming

    timing = SensorTiming(0.4)
    for n, most in ((2, 0.04), (4, 0.1)):
        sim = list(simulate(data.astronaut(), Motion.steps([(64.0, 38.4)], [100.0]), timing,
                            n, size=(320, 180)))
        _, traj = correct_frames([s.rolling for s in sim], timing)
        ratio = [displacement_error(f, s.motion) / displacement_error(None, s.motion)
                 for f, s in zip(traj.frames, sim, strict=True)]
        assert max(ratio) < most, (n, ratio)


def test_a_rows_flow_by_the_camera_model_lands_on_the_row_read_there():
    """In a pan of 80 x 48 px a frame down (readout 1.0), a row's content lies in the
    previous frame 48 / (1 - 48 / 180) = 65.5 rows up, read 65.5 rows' time earlier, so
    80 * (1 + 65.5 / 180) = 109.1 px left: the flow the content entering takes (it took
    the same row's -80 x -48)."""
    from skimage import data

    from unjello.pipeline import correct_frames
    from unjello.simulate import Motion, simulate
    from unjello.timing import SensorTiming

    timing = SensorTiming(1.0)
    sim = list(simulate(data.astronaut(), Motion.steps([(80.0, 48.0)], [100.0]), timing, 2,
                        size=(320, 180)))
    _, traj = correct_frames([s.rolling for s in sim], timing)
    flow = dict(traj.frames[1].neighbours)[-1]
    entered = np.median(flow[100:170, 5:60].reshape(-1, 2), axis=0)  # the previous saw none
    assert np.allclose(entered, (-109.1, -65.45), atol=0.5), entered


def test_a_region_kept_whole_falls_back_on_its_rows_camera_motion(monkeypatch):
    """Where a region is given the motion around it, deep inside it the camera's takes
    over: the scanline's whole camera motion (eq. 26 with the rows' velocity), which a
    steady pan splits between the trajectory and the rows' velocity. Given the
    trajectory's part alone, a 25 %-a-frame pan's kept regions at the bottom of the
    frame moved by half their displacement."""
    from skimage import data

    import unjello.motion.dense.safety as dense_safety
    from tests.clips import pole_pan
    from unjello.pipeline import correct_frames
    from unjello.timing import SensorTiming

    cameras = []
    keep_whole = dense_safety.keep_whole

    def spy(field, camera, *args, **kwargs):
        cameras.append(np.array(camera))
        return keep_whole(field, camera, *args, **kwargs)

    monkeypatch.setattr(dense_safety, "keep_whole", spy)
    sim, _ = pole_pan(data.astronaut(), 0.25, 1.0, frames=7)
    _, traj = correct_frames([s.rolling for s in sim], SensorTiming(1.0))
    assert cameras  # the poles' folds called for it
    truths = [s.motion.displacement for s in sim]
    for camera in cameras:  # each against the frame whose camera it is
        err = min(np.abs(camera - t).max() for t in truths)
        assert err < 1.0  # measured 0.12; the trajectory's part alone: 26 px off
