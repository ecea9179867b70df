import json

import numpy as np
import pytest

from unjello.errors import SettingsError
from unjello.simulate import Motion, motion_from_spec, simulate
from unjello.timing import SensorTiming


def test_tiny_readout_gives_global_shutter(scene):
    frames = list(simulate(scene, Motion("pan", speed=6), SensorTiming(1e-6), 3,
                           size=(160, 120)))
    for f in frames:
        assert np.abs(f.rolling.astype(int) - f.truth).max() <= 1
        assert np.abs(f.motion.displacement).max() < 1e-3


def test_true_displacement_matches_pan(scene):
    timing = SensorTiming(0.5)
    f = next(simulate(scene, Motion("pan", speed=8), timing, 1, size=(160, 120)))
    t = timing.row_times(120)
    assert np.allclose(f.motion.displacement[:, 0], 8 * (t - timing.reference_time(120)))
    assert np.allclose(f.motion.velocity[:, 0], 8.0)


def test_rolling_rows_come_from_their_own_time(scene):
    # Row r of the RS frame equals row r of the GS frame rendered at t_r.
    timing = SensorTiming(1.0, reference="first")
    rs = next(simulate(scene, Motion("pan", speed=10), timing, 1, size=(160, 120)))
    assert np.array_equal(rs.rolling[0], rs.truth[0])
    assert not np.array_equal(rs.rolling[-1], rs.truth[-1])


def test_motion_json(tmp_path):
    p = tmp_path / "m.json"
    p.write_text(json.dumps({"time_unit": "s", "t": [0, 0.1, 0.2, 0.3], "dx": [0, 3, 6, 9],
                             "dy": [0, 0, 1, 0]}))
    m = motion_from_spec(str(p), fps=30)
    assert m(np.array([3.0]))[0, 0] == pytest.approx(3.0)


def test_unknown_motion():
    with pytest.raises(SettingsError):
        motion_from_spec("wobble")


@pytest.mark.parametrize("kind", ["shake", "jello", "stop", "diagonal"])
def test_motions_are_finite(kind):
    d = Motion(kind)(np.linspace(0, 30, 301))
    assert d.shape == (301, 2) and np.isfinite(d).all()
