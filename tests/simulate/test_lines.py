"""The street scene: its verticals lean as asked, the roll turns it all."""

import cv2
import numpy as np
import pytest

from unjello.readout.lines import frame_segments
from unjello.simulate import street_scene


@pytest.mark.parametrize("lean", [0.0, 0.05])
def test_the_verticals_lean_as_asked(lean):
    grey = cv2.cvtColor(street_scene((640, 480), lean=lean), cv2.COLOR_RGB2GRAY)
    segs, roll = frame_segments(grey)
    assert len(segs) > 10
    assert np.median(segs[:, 2]) == pytest.approx(lean, abs=0.004)
    assert roll is None or abs(roll) < 0.004  # the horizontals stay horizontal


def test_a_roll_turns_verticals_and_horizontals_alike():
    grey = cv2.cvtColor(street_scene((640, 480), roll=0.04), cv2.COLOR_RGB2GRAY)
    segs, roll = frame_segments(grey)
    assert roll is not None and abs(roll) == pytest.approx(0.04, abs=0.005)
    # Verticals lean the other way by as much: roll-corrected, they are upright.
    assert np.median(segs[:, 2]) + roll == pytest.approx(0.0, abs=0.005)
