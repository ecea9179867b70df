import numpy as np
import pytest

from unjello.errors import SettingsError
from unjello.timing import (
    DIRECTIONS,
    SensorTiming,
    from_top_bottom,
    parse_readout,
    to_top_bottom,
)


@pytest.mark.parametrize("text, fps, expected", [
    ("0.9", None, 0.9), ("1", None, 1.0), (0.5, None, 0.5), ("15.7ms", 30.0, 0.471),
    ("33.3 ms", 30.0, 0.999),
])
def test_parse_readout(text, fps, expected):
    assert parse_readout(text, fps) == pytest.approx(expected)


@pytest.mark.parametrize("text", ["0", "-1", "2", "abc", "nan", "inf", "40ms"])
def test_parse_readout_rejects(text):
    with pytest.raises(SettingsError):
        parse_readout(text, 30.0)


def test_ms_needs_fps():
    with pytest.raises(SettingsError, match="frame rate"):
        parse_readout("10ms")


def test_row_times_and_reference():
    t = SensorTiming(0.6, reference="middle")
    rows = t.row_times(5, start=3.0)
    assert rows[0] == 3.0
    assert np.allclose(np.diff(rows), 0.6 / 5)
    assert t.reference_time(5, 3.0) == pytest.approx(3.0 + 0.6 * 2 / 5)
    assert SensorTiming(0.6, reference="first").reference_time(5, 3.0) == 3.0


def test_invalid_timing():
    with pytest.raises(SettingsError):
        SensorTiming(1.5)
    with pytest.raises(SettingsError):
        SensorTiming(1.0, direction="diagonal")  # type: ignore[arg-type]


@pytest.mark.parametrize("direction", DIRECTIONS)
def test_direction_round_trip(direction):
    a = np.arange(2 * 3 * 3).reshape(2, 3, 3)
    tb = to_top_bottom(a, direction)
    assert np.array_equal(from_top_bottom(tb, direction), a)


def test_direction_first_line():
    a = np.arange(12).reshape(3, 4)
    # The first line read becomes row 0.
    assert to_top_bottom(a, "bottom-top")[0].tolist() == a[-1].tolist()
    assert to_top_bottom(a, "left-right")[0].tolist() == a[:, 0].tolist()
    assert to_top_bottom(a, "right-left")[0].tolist() == a[:, -1].tolist()
