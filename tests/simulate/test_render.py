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


@pytest.mark.parametrize("kind", ["propeller", "wheel"])
def test_spinning_layers_have_exact_truth(scene, kind):
    """A global shutter sees the spinning object as its truth; the truth's field moves each
    of its pixels along the rotation."""
    from unjello.simulate import scene_layers

    tiny = list(simulate(scene, Motion("pan", speed=5.0), SensorTiming(1e-6), 2,
                         size=(160, 120), layers=kind))
    assert np.abs(tiny[1].rolling.astype(int) - tiny[1].truth).max() <= 1
    rs = list(simulate(scene, Motion("pan", speed=5.0), SensorTiming(1.0), 2, size=(160, 120),
                       layers=kind))[1]
    on = rs.layer == 1
    assert 0.03 < on.mean() < 0.3
    layer = scene_layers(kind, scene[::-1].astype(np.float32), Motion("pan", speed=5.0),
                         (160, 120))[0]
    ys, xs = np.nonzero(on)
    p = np.stack([xs, ys], axis=1).astype(float)
    t_rows = SensorTiming(1.0).row_times(120, 1.0)[ys]
    t_ref = SensorTiming(1.0).reference_time(120, 1.0)
    expected = p - layer.place(layer.source(p, t_rows), np.full(len(p), t_ref))
    assert np.allclose(rs.motion.field[ys, xs], expected, atol=1e-6)
    # Far from the reference row the blades have turned a good way: tens of pixels.
    assert np.abs(expected).max() > 10
