"""Where a clip breaks: cuts and size changes, not pans, fades, flashes or parallax."""

import numpy as np
from skimage import data

from unjello.motion.cuts import Breaks, similarity, tones
from unjello.simulate import Motion, simulate
from unjello.timing import SensorTiming


def _grey(frames):
    return [f.astype(np.float32).mean(axis=2) for f in frames]


def _pan(image, n, speed=12.0):
    return _grey([s.rolling for s in simulate(image, Motion("pan", speed=speed),
                                              SensorTiming(0.9), n, size=(320, 180))])


def _breaks(frames, resized=()):
    """Why the clip breaks before each frame, decided as the corrector does: one frame late."""
    b, out = Breaks(), []
    for i, f in enumerate(frames):
        b.add(f, "size" if i in resized else None)
        if i:
            out.append(b.before(2))
    return out + [b.before(1)]


def test_a_cut_between_two_scenes_breaks_there_alone():
    frames = _pan(data.astronaut(), 5) + _pan(data.chelsea(), 5)
    assert _breaks(frames) == [None] * 5 + ["cut"] + [None] * 4


def test_a_fade_and_a_fast_pan_do_not_break():
    frames = _pan(data.rocket(), 10, speed=45.0)
    gains = np.linspace(1.0, 0.15, 10)
    assert _breaks([f * g for f, g in zip(frames, gains, strict=True)]) == [None] * 10


def test_a_flash_keeps_its_motion():
    frames = _pan(data.chelsea(), 6)
    frames[3] = np.clip(frames[3] * 1.6 + 50, 0, 255)
    assert _breaks(frames) == [None] * 6


def test_a_size_change_breaks_whatever_the_picture():
    frames = _pan(data.chelsea(), 4)
    assert _breaks(frames, resized={2}) == [None, None, "size", None]


def test_similarity_and_tones_tell_one_scene_from_another():
    a, b = _pan(data.astronaut(), 2)
    c = _pan(data.coffee(), 1)[0]
    assert similarity(a, b) > 0.9 > 0.6 > similarity(a, c)
    assert tones(a, b) < 0.1 < 0.3 < tones(a, c)
    assert tones(a, 0.3 * a) < 0.05  # a gain (a fade) keeps the tones


def test_a_pan_of_half_the_width_a_frame_past_near_poles_keeps_its_pace():
    # The rocket leaves and the tower enters: pairs match as poorly as a cut, with other
    # tones, but each keeps the pace of the pairs around it.
    from tests.clips import pole_pan

    for share in (0.4, 0.5):
        sim, _ = pole_pan(data.rocket(), share, 0.7)
        assert _breaks(_grey([s.rolling for s in sim])) == [None] * len(sim)
