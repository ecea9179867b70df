"""The camera trajectory solve at scanline resolution."""

import numpy as np

from unjello.motion.dense.camera import solve_camera_trajectory


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


def test_robust_rounds_keep_an_abrupt_start_sharp():
    # Still until t = 2.3, then 8 px per frame interval: the quadratic penalty rounds the
    # start over about a frame; the reweighted one keeps it within a few grid steps.
    h, step = 120, 1.0 / 32
    ks = np.repeat(np.arange(1, 8), h)
    y = np.tile(np.arange(h), 7).astype(float)
    ta, tb = ks + 0.7 * y / h, ks - 1 + 0.7 * y / h

    def d(t):
        return 8.0 * np.maximum(t - 2.3, 0.0)

    delta = np.stack([d(ta) - d(tb), np.zeros_like(ta)], axis=1)
    errors = []
    for robust in (0, 3):
        sol = solve_camera_trajectory(ta, tb, None, delta, np.ones_like(ta), step, 1e-4,
                                      robust=robust)
        grid = sol.t0 + sol.step * np.arange(len(sol.c))
        t = np.linspace(1.5, 3.5, 200)
        est = np.interp(t, grid, sol.c[:, 0])
        est -= est[0] - d(t)[0]
        errors.append(np.abs(est - d(t)).max())
    assert errors[1] < 0.5 * errors[0]


def test_rows_no_equation_reaches_keep_the_velocity_of_the_rows_beside_them():
    # A constant pan of 64 px a frame, readout 0.4: the top fifth of every frame's rows
    # entered it and has no equation (a fast diagonal pan). Those rows' camera velocity
    # (the path's plus the row velocity's) stays the pan's instead of falling to the
    # path's alone.
    h, rho, v = 90, 0.4, 64.0
    y = np.arange(int(0.22 * h), h, dtype=float)
    ks = np.repeat(np.arange(1, 5), y.size)
    yy = np.tile(y, 4)
    ta, tb = ks + rho * yy / h, ks - 1 + rho * yy / h
    delta = np.stack([v * (ta - tb), np.zeros_like(ta)], axis=1)
    sol = solve_camera_trajectory(ta, tb, yy / (h - 1), delta, np.ones_like(ta), rho / 32,
                                  3e-3)
    path = np.gradient(sol.c[:, 0], sol.step)[len(sol.c) // 2]
    assert abs(path + sol.u[0, 0] - v) < 0.03 * v  # the top row: unseen by any equation
    assert abs(path + sol.u[-1, 0] - v) < 0.01 * v


def test_reweighting_follows_a_vibration_about_as_the_plain_solve_does():
    # The 23 Hz vibration above on a pan, with the row velocity and the default
    # smoothness, which follow it only in part (misfits 1.25 px on average, 3.2 at most):
    # the rows it leaves are spread over every frame, and weighed down they change the
    # path little (measured: the mean misfit 1.5 % higher).
    from unjello.motion.dense.camera import solve_reweighted

    h, rho = 120, 0.7

    def d(t):
        return 40.0 * t + 2.0 * np.sin(2 * np.pi * 23 / 30 * t)

    ks = np.repeat(np.arange(1, 8), h)
    y = np.tile(np.arange(h), 7).astype(float)
    ta, tb = ks + rho * y / h, ks - 1 + rho * y / h
    delta = np.stack([d(ta) - d(tb), np.zeros_like(ta)], axis=1)
    args = (ta, tb, y / (h - 1), delta, np.ones_like(ta), 1 / 256, 0.003)
    plain, again = solve_camera_trajectory(*args), solve_reweighted(*args)

    def misfit(sol):
        return np.abs(sol.differences(*args[:3]) - delta)[:, 0].mean()

    assert misfit(again) < 1.05 * misfit(plain)


def test_reweighting_outvotes_rows_that_followed_a_near_object():
    # A 128 px a frame pan over seven pairs; the top 40 % of one pair's rows read the
    # speed of a pole 1.3 times as near (166), as the rocket 40 %/0.7 clip's pair 3-4 did.
    from unjello.motion.dense.camera import solve_reweighted

    h, rho = 90, 0.7
    ks = np.repeat(np.arange(1, 8), h)
    y = np.tile(np.arange(h), 7).astype(float)
    ta, tb = ks + rho * y / h, ks - 1 + rho * y / h
    delta = np.tile([128.0, 0.0], (ta.size, 1))
    bad = (ks == 4) & (y < 0.4 * h)
    delta[bad, 0] = 166.0
    args = (ta, tb, y / (h - 1), delta, np.ones_like(ta), 1 / 256, 0.003)
    plain, again = solve_camera_trajectory(*args), solve_reweighted(*args)

    def off(sol):
        return np.abs(sol.differences(*args[:3])[~bad, 0] - 128.0)

    # The plain solve splits the difference (measured: 11.9 px at worst, median 2.4);
    # reweighted, 2.2 and 0.55.
    assert off(plain).max() > 5.0 and np.median(off(plain)) > 2.0
    assert off(again).max() < off(plain).max() / 3 and np.median(off(again)) < 0.7
