import numpy as np
import pytest

from unjello.motion.paper.velocity import (
    bernstein,
    bezier_control_points,
    bezier_eval,
    global_sample_time,
    initial_velocity,
    scanline_velocity,
)


def test_bernstein_partition_of_unity():
    lam = np.linspace(0, 1, 11)
    assert np.allclose(bernstein(lam).sum(axis=-1), 1.0)


def test_bezier_reproduces_cubic_through_four_samples():
    # Eq. 15-18: samples at lambda = 0, 1/3, 2/3, 1 of a cubic; eq. 14 reproduces it.
    def cubic(t):
        return np.stack([2 - t + 0.5 * t**2 - 0.3 * t**3, 4 * t**3 - t], axis=-1)

    lam = np.array([0, 1 / 3, 2 / 3, 1])
    ctrl = bezier_control_points(lam, cubic(lam))
    grid = np.linspace(0, 1, 50)
    assert np.allclose(bezier_eval(np.broadcast_to(ctrl, (50, 4, 2)), grid), cubic(grid))


def test_scanline_velocity_eq19_uneven_samples():
    ts = np.array([0.0, 0.7, 2.1, 2.9, 4.0])
    def f(t):
        return np.stack([t**3 - 2 * t, 0.5 * t**2], axis=-1)

    q = np.linspace(0.7, 2.9, 30)
    assert np.allclose(scanline_velocity(ts, f(ts), q), f(q))


def test_scanline_velocity_clamps_outside():
    ts = np.array([1.0, 2.0])
    vs = np.array([[1.0, 0.0], [3.0, 0.0]])
    out = scanline_velocity(ts, vs, np.array([0.0, 1.5, 5.0]))
    assert out[:, 0].tolist() == pytest.approx([1.0, 2.0, 3.0])


def test_single_sample_is_constant():
    out = scanline_velocity(np.array([3.0]), np.array([[2.0, -1.0]]), np.linspace(0, 9, 4))
    assert np.allclose(out, [[2.0, -1.0]] * 4)


def test_eq13_and_sample_time():
    assert initial_velocity(np.array([6.0, 3.0]), 2.0).tolist() == [3.0, 1.5]
    # Paper's rho = 1: sample of g(n) at the midpoint of middle scanlines n-1 and n.
    assert global_sample_time(4.0, 5.0, 1.0, 1001) == pytest.approx(5.0, abs=1e-3)
    assert global_sample_time(4.0, 5.0, 0.6, 1001) == pytest.approx(4.8, abs=1e-3)


def test_eq10_interval_includes_the_vertical_motion():
    """Content that moved g_y rows down was imaged g_y / h of a readout later in frame n
    than in frame n - 1: the interval is dt + rho g_y / h, not dt."""
    rho, h, v = 0.6, 360, np.array([17.5, 8.5])
    g_y = v[1] / (1 - rho * v[1] / h)  # what the frames show (inverse of eq. 10)
    g = np.array([v[0] * (1 + rho * g_y / h), g_y])
    assert np.allclose(initial_velocity(g, 1.0, rho, h), v)
    assert initial_velocity(g, 1.0)[1] == pytest.approx(1.0145 * v[1], rel=1e-3)
    # The sample sits at the middle of that interval: earlier by half its extra length.
    assert (global_sample_time(4.0, 5.0, rho, h, g_y)
            == pytest.approx(global_sample_time(4.0, 5.0, rho, h) - rho * g_y / (2 * h)))
