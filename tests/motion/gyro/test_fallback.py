"""The gyro method handing the clip to the dense method when the gyro does not fit."""

import numpy as np
import pytest

from unjello.gyrolog import GyroConfig, GyroLog
from unjello.motion.dense.method import DenseConfig, DenseMethod
from unjello.motion.gyro.fallback import GyroOrDense
from unjello.motion.gyro.method import GyroMismatch
from unjello.simulate import Motion, gyro_samples, simulate
from unjello.timing import SensorTiming

TIMING = SensorTiming(1.0)
PAN = Motion("pan", fps=25.0, speed=6.0)


@pytest.fixture(scope="module")
def pan(scene):
    """12 grey frames of a pan, and the dense method's motion of them."""
    frames = [s.rolling.mean(axis=2).astype(np.float32)
              for s in simulate(scene, PAN, TIMING, 12, size=(192, 144))]
    dense = DenseMethod(TIMING, DenseConfig())
    motions = [m for i, f in enumerate(frames) for m in dense.push(f, float(i))]
    return frames, motions + dense.flush()


def _run(method, frames):
    out = [m for i, f in enumerate(frames) for m in method.push(f, float(i))]
    return out + method.flush()


def _same(a, b):
    assert len(a) == len(b) == 12
    for x, y in zip(a, b, strict=True):
        assert np.array_equal(x.displacement, y.displacement)


@pytest.mark.parametrize("sync", [8, 30])  # handed over while pushing / at the flush
def test_a_gyro_that_does_not_fit_hands_over_every_frame(pan, sync):
    """A gimbal-still gyro under a panning picture: the frames its calibration held go to
    the dense method, whose motion is then exactly what asking for it gives."""
    frames, dense = pan
    t = np.arange(-1.0, 2.0, 1 / 400)
    still = GyroLog(t, np.random.default_rng(3).normal(0.0, 2e-3, (t.size, 3)))
    method = GyroOrDense(TIMING, still, GyroConfig(sync_frames=sync), DenseConfig(), 25.0,
                         fallback=True)
    _same(_run(method, frames), dense)
    assert method.method == "dense" and "row motion" in method.fallback
    assert method.agreement is not None and method.agreement < 0.3
    with pytest.raises(GyroMismatch):  # without a fallback, a log that does not fit is an error
        _run(GyroOrDense(TIMING, still, GyroConfig(sync_frames=sync), DenseConfig(), 25.0),
             frames)


def test_a_gyro_known_not_to_describe_the_picture_is_measured_but_not_used(pan):
    """The camera stabilised its picture itself: its gyro (here one that fits) is
    calibrated only to say how much it explains, and the dense method measures."""
    frames, dense = pan
    t, rates = gyro_samples(PAN, 1500.0, 12 / 25)
    method = GyroOrDense(TIMING, GyroLog(t, rates), GyroConfig(sync_frames=8), DenseConfig(),
                         25.0, fallback="stabilised in camera")
    _same(_run(method, frames), dense)
    assert method.method == "dense" and method.fallback == "stabilised in camera"
    assert method.agreement is not None and method.agreement > 0.9
    assert method.pose(3.0) is None


def test_a_fitting_gyro_is_used(pan):
    frames, _ = pan
    t, rates = gyro_samples(PAN, 1500.0, 12 / 25)
    method = GyroOrDense(TIMING, GyroLog(t, rates), GyroConfig(sync_frames=8), DenseConfig(),
                         25.0, fallback=True)
    assert len(_run(method, frames)) == 12
    assert method.method == "gyro" and method.fallback == "" and method.agreement > 0.9
    assert method.pose(3.0) is not None
