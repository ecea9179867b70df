"""End to end on simulated clips, both methods: the error must drop by the stated factors.

The dense and paper methods' own quality tests: tests/motion/dense/test_quality.py,
tests/motion/paper/test_quality.py.
"""

import numpy as np
import pytest

from tests.quality import run_simulated as _run
from unjello.config import CorrectionConfig
from unjello.metrics import psnr
from unjello.simulate import Motion
from unjello.timing import DIRECTIONS, SensorTiming

METHOD = pytest.mark.parametrize("method", ["paper", "dense"])

@METHOD
@pytest.mark.parametrize("kind", ["pan", "diagonal"])
@pytest.mark.parametrize("rho", [1.0, 0.6])
def test_pan_error_drops_8x(scene, kind, rho, method):
    _, out, traj, err, unc = _run(scene, Motion(kind, speed=6.7), SensorTiming(rho),
                                  config=CorrectionConfig(method=method))
    assert len(out) == len(traj) == 10
    assert err.mean() * 8 <= unc.mean(), (err.mean(), unc.mean())


@METHOD
@pytest.mark.parametrize("rho", [1.0, 0.6])
def test_sudden_stop_no_overcompensation(scene, rho, method):
    # The paper's Fig. 7: pan, then stop at t = 5; the frames after it must stay put.
    _, _, traj, err, unc = _run(scene, Motion("stop", speed=7.0, stop_at=5.0),
                                SensorTiming(rho), n=10, config=CorrectionConfig(method=method))
    after = np.array([f.start >= 5.0 for f in traj.frames])
    assert err[after].max() <= 0.5, err
    assert err.mean() * 8 <= unc.mean()


@METHOD
@pytest.mark.parametrize("direction", DIRECTIONS)
def test_every_direction_same_quality(scene, direction, method):
    timing = SensorTiming(0.9, direction=direction)
    _, _, _, err, unc = _run(scene, Motion("diagonal", speed=5.3), timing, n=8,
                             config=CorrectionConfig(method=method))
    assert err.mean() * 8 <= unc.mean()
    assert err.mean() < 0.15


def test_reference_first_scanline(scene):
    timing = SensorTiming(0.8, reference="first")
    sim, out, traj, err, unc = _run(scene, Motion("pan", speed=6.1), timing, n=8)
    assert err.mean() * 8 <= unc.mean()
    assert np.abs(traj.frames[3].displacement[0]).max() < 1e-9


def test_variable_frame_rate_uses_timestamps(scene):
    starts = np.array([0, 1, 2.5, 3.5, 4.2, 5.2, 6.8, 7.8])
    _, _, traj, err, unc = _run(scene, Motion("pan", speed=6.0), SensorTiming(1.0), n=8,
                                starts=starts)
    assert [f.start for f in traj.frames] == starts.tolist()
    assert err.mean() * 8 <= unc.mean()


@pytest.mark.slow
def test_splat_warp_improves_psnr(scene):
    config = CorrectionConfig(method="paper", warp="splat", fill="black")
    sim, out, traj, err, unc = _run(scene, Motion("pan", speed=7.0), SensorTiming(1.0), n=6,
                                    config=config)
    m = 16
    before = np.mean([psnr(s.rolling, s.truth, m) for s in sim])
    after = np.mean([psnr(o, s.truth, m) for o, s in zip(out, sim, strict=True)])
    assert after > before + 8, (before, after)


def test_still_camera_is_untouched(scene):
    sim, out, traj, err, unc = _run(scene, Motion("pan", speed=0.0), SensorTiming(1.0), n=4)
    assert np.abs(traj.displacements()).max() < 0.05
    assert all(np.abs(o.astype(int) - s.rolling).max() <= 1 for o, s in zip(out, sim, strict=True))
