"""Nearer objects leaving the frame at a side, carried beyond its edge by their own motion."""

import cv2
import numpy as np
import pytest

from unjello.timing import SensorTiming
from unjello.trajectory import FrameMotion
from unjello.warp.fill.leaving import (
    BAND,
    EdgeObject,
    _covered,
    _overtaken,
    _standing_out,
    edge_objects,
    objects_beyond,
    settled_objects,
)
from unjello.warp.fill.neighbours import INSET
from unjello.warp.warper import PictureWarper

H, W = 120, 80
REF = (H - 1) / 2  # readout 1, the middle row
BACK, NEAR = 20.0, 30.0  # px a frame: the background, and a pole nearer (1.5x)
POLE = (70.0, 74.0)  # the pole's columns at the reference time


def _tau(y: np.ndarray) -> np.ndarray:
    return (y - REF) / H


def _pan(pole: bool = True) -> dict:
    """A pan over a texture with a flat pole leaving the frame at the right, rolling shutter.

    Content at ``p`` (reference time) is at ``p + v (t - t_ref)`` at time ``t``; row ``y``
    of this frame is read at ``tau(y)``, of the previous at ``tau(y) - 1``. The pole (250)
    leaves the frame in the rows read after ``tau = 0.33`` (row 99): the frame never saw
    it there, the previous frame did, 30 px further left.
    """
    rng = np.random.default_rng(5)
    tex = rng.uniform(40, 160, (H, W + 200)).astype(np.float32)
    tex = (tex + np.roll(tex, 1, 1) + np.roll(tex, 1, 0)) / 3  # (a little smoother)

    def scene(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return tex[y, np.clip(np.rint(x).astype(int) + 100, 0, W + 199)]

    y, x = np.mgrid[0:H, 0:W].astype(np.float32)
    t = _tau(y)
    out = {}
    for name, dt in (("frame", 0.0), ("prev", -1.0)):
        img = scene(x - BACK * (t + dt), y.astype(int))
        at = x - NEAR * (t + dt)  # the pole's reference position seen at (x, y)
        if pole:
            img[(at >= POLE[0]) & (at <= POLE[1])] = 250.0
        out[name] = img
    field = np.zeros((H, W, 2), np.float32)
    field[..., 0] = BACK * t
    if pole:
        at = x - NEAR * t
        on = (at >= POLE[0]) & (at <= POLE[1])
        field[..., 0][on] = (NEAR * t)[on]
    # (a measured field's error: the core is its fastest quartile, which on an exact
    # field is decided by rounding, where tau is least)
    out["field"] = field + np.random.default_rng(0).normal(0, 0.002, field.shape).astype(
        np.float32)
    # This frame's flow to the previous: the background's everywhere (the flow lost the
    # flat pole, as DIS does; only the field, from the rigid fit, knows its motion).
    flow = np.zeros((H, W, 2), np.float32)
    flow[..., 0] = -BACK
    out["flow"] = flow
    return out


def test_edge_objects_find_the_pole_touching_the_side_and_its_velocity():
    objs = edge_objects(_pan()["field"], 1.0, REF)
    assert len(objs) == 1
    obj = objs[0]
    assert obj.side == 1
    assert abs(obj.velocity[0] - NEAR) < 0.5 and abs(obj.velocity[1]) < 0.1
    assert abs(obj.behind[0] - BACK) < 0.5
    assert obj.rows.min() >= 67 and obj.rows.max() <= 84  # where it crosses the band
    # A plain pan has none; nor does a background that does not move as one.
    assert edge_objects(_pan(pole=False)["field"], 1.0, REF) == []
    uneven = _pan()["field"]
    uneven[..., 0] *= np.linspace(0.5, 1.5, W)[None, :]
    assert edge_objects(uneven, 1.0, REF) == []


def test_edge_objects_find_a_pole_leaving_just_after_the_reference_row():
    # A pole crossing the side in the rows read 0.07-0.16 of the readout after the
    # reference (as in the astronaut 25 %/1.0 clip's frame 3): with NEAR_REFERENCE 0.1
    # too few rows were left to measure it, and it was not found.
    y, x = np.mgrid[0:H, 0:W].astype(np.float32)
    t = _tau(y)
    field = np.zeros((H, W, 2), np.float32)
    field[..., 0] = BACK * t
    at = x - NEAR * t  # the pole's reference position seen at (x, y)
    on = (at >= 71.0) & (at <= 74.0)
    field[..., 0][on] = (NEAR * t)[on]
    field += np.random.default_rng(0).normal(0, 0.05, field.shape).astype(np.float32)
    objs = edge_objects(field, 1.0, REF)
    assert len(objs) == 1 and objs[0].side == 1
    assert abs(objs[0].velocity[0] - NEAR) < 1.0
    assert objs[0].rows.min() >= REF + 0.07 * H - 1


def test_edge_objects_know_the_background_beside_each_core_pixel():
    pan = _pan()
    obj = edge_objects(pan["field"], 1.0, REF)[0]
    assert obj.beside is not None and (obj.beside >= 0).all()
    assert (obj.beside < obj.cols).all()  # inward of a pole at the right side
    # the first column inward whose field is the background's
    v = pan["field"][obj.rows, obj.beside, 0] / _tau(obj.rows)
    assert np.abs(v - BACK).max() < 1.0
    start = W - 1 - int(INSET) - BAND + 1  # the band's inner column
    between = [pan["field"][r, b + 1:start, 0] / _tau(r) for r, b in
               zip(obj.rows, obj.beside, strict=True)]  # the pole, inward of the band
    assert all(np.all(np.abs(x - NEAR) < np.abs(x - BACK)) for x in between)


def test_a_core_all_like_the_background_beside_it_is_looked_for_among_slower_pixels():
    # The field gave the pole's velocity to flat background above it (rows 66-75, as
    # DIS's flow spreads over a black wall); the pole itself (250) shows in rows 76-84,
    # whose field is a little slower.
    own = np.full((H, W), 100.0, np.float32)
    own[76:85, 76:80] = 250.0
    core = np.repeat(np.arange(66, 76), 4), np.tile(np.arange(76, 80), 10)
    wider = np.repeat(np.arange(76, 85), 4), np.tile(np.arange(76, 80), 9)
    obj = EdgeObject(1, *core, (NEAR, 0.0), (BACK, 0.0), np.full(40, 60),
                     (*wider, np.full(36, 60)))
    kept, look = _standing_out(obj, own, own[core][:, None], (1.0, 1.0))
    assert sorted(set(kept.rows.tolist())) == list(range(76, 85))
    assert look.shape == (36, 1) and np.all(look == 250.0)
    # A core partly unlike the background (RUN pixels or more) is kept as it was.
    own[70:76, 76:80] = 250.0
    kept, look = _standing_out(obj, own, own[core][:, None], (1.0, 1.0))
    assert np.array_equal(kept.rows, core[0]) and kept.wider is None
    assert look.shape == (40, 1)


def test_settled_objects_correct_the_velocity_and_drop_what_a_flat_scene_matches():
    pan = _pan()
    obj = edge_objects(pan["field"], 1.0, REF)[0]
    off = EdgeObject(obj.side, obj.rows, obj.cols, (NEAR - 5.0, 0.0), obj.behind)
    kept, = settled_objects([off], pan["frame"], [pan["prev"]], [-1.0], (H, W))
    assert abs(kept.velocity[0] - NEAR) <= 2.0  # the pole's 5 columns: within its width
    flat = np.full((H, W), 250.0, np.float32)
    assert settled_objects([obj], flat, [flat], [-1.0], (H, W)) == []


def test_the_warper_carries_the_pole_beyond_the_edge_from_the_previous_frame():
    pan = _pan()
    d = np.zeros((H, 2))
    chroma = [cv2.resize(pan[k], (W // 2, H // 2), interpolation=cv2.INTER_AREA)
              for k in ("frame", "prev")]
    motion = FrameMotion(0, 0.0, d, np.zeros((H, 2)), field=pan["field"],
                         neighbours=((-1, pan["flow"]),))
    warper = PictureWarper(SensorTiming(1.0))
    out, u = warper([pan["frame"], chroma[0]], motion, {-1: [pan["prev"], chroma[1]]})
    rows = slice(100, H - 2)  # read after the pole left the frame
    # Its middle, and 3 of its 5 columns in every row (where the previous frame's sample
    # blends the pole's edge with the background, it is not taken as the pole).
    assert np.all(out[rows, 72] >= 245.0)  # (the texture is 40-160, the pole 250)
    assert np.all((out[rows, 69:76] >= 245.0).sum(axis=1) >= 3)
    # The chroma plane follows (the texture is 40-160: only the pole is brighter).
    assert np.all(u[50:59, 34:38].max(axis=1) > 180.0)
    # Beside it, the background the previous frame saw (as without the pole's motion).
    plain = PictureWarper(SensorTiming(1.0))([pan["frame"]], FrameMotion(
        0, 0.0, d, np.zeros((H, 2)), field=_pan(pole=False)["field"],
        neighbours=((-1, pan["flow"]),)), {-1: [_pan(pole=False)["prev"]]})[0]
    right = slice(int(POLE[1]) + 2, W)
    assert np.abs(out[rows, right] - plain[rows, right]).mean() < 1.0


def test_objects_beyond_reads_the_background_beside_the_pole_at_its_own_motion():
    """Beside a pole touching the right side, the flow carried past the edge is the pole's
    (DIS blends it across the outline): a strip pixel of background is read where the
    pole's motion carries it (30 px a frame) instead of its own (20). Where that sample
    shows no pole within two pixels, it is read at the background's motion instead; one
    read at the background's motion already, or next to the pole (its blurred outline),
    is left alone; the half-size plane follows the first's decisions."""
    h, w, ref = 40, 80, 19.5
    rng = np.random.default_rng(3)
    prev = rng.uniform(100, 160, (h, w)).astype(np.float32)
    prev[:, 20:25] = 40.0  # the pole, as the previous frame saw it
    own = rng.uniform(100, 160, (h, w)).astype(np.float32)
    own[:, 76:] = 40.0
    obj = EdgeObject(1, np.repeat(np.arange(10, 30), 4), np.tile(np.arange(76, 80), 20),
                     (30.0, 0.0), (20.0, 0.0))
    y = 31

    def read(v: float, x: float) -> float:  # where motion v carries (x, y) in the previous
        return x + v * ((y - ref) / h - 1.0)

    xs = np.array([71, 73, 75])
    #          the pole's motion (texture), the background's, the pole's (1 px from it)
    nx = np.array([read(30.0, 71), read(20.0, 73), 25.5], np.float32)
    parts = [(0, np.full(3, y), xs, nx, np.full(3, float(y), np.float32))]
    out, decided = objects_beyond(parts, [obj], (h, w), 1.0, ref, [-1.0], [-1], own, [prev])
    got = {int(x): float(n) for part in out if part[0] == 0
           for x, n in zip(part[2], part[3], strict=True)}
    assert got == pytest.approx({71: read(20.0, 71), 73: read(20.0, 73), 75: 25.5})
    half = [(0, np.full(3, y // 2), xs // 2, nx / 2, np.full(3, y / 2, np.float32))]
    out2, _ = objects_beyond(half, [obj], (h, w), 1.0, ref, [-1.0], [-1], None,
                             [cv2.resize(prev, (w // 2, h // 2))], decided)
    got2 = {int(x): float(n) for part in out2 if part[0] == 0
            for x, n in zip(part[2], part[3], strict=True)}
    assert got2[35] == pytest.approx((read(20.0, 71) + 0.5) / 2 - 0.5, abs=0.6)
    assert got2[37] == pytest.approx(25.5 / 2)


def test_settled_objects_keep_a_pole_narrower_than_its_core():
    """A thin pole's core band holds background beside it (half of it here, of which the
    pole's speed carries a third onto alike texture: 68 % held); the pole is kept."""
    pan = _pan()
    obj = edge_objects(pan["field"], 1.0, REF)[0]
    rows, cols = np.concatenate([obj.rows, obj.rows]), np.concatenate([obj.cols, obj.cols - 8])
    order = np.argsort(rows, kind="stable")  # rows ascending, as edge_objects gives them
    wide = EdgeObject(obj.side, rows[order], cols[order], obj.velocity, obj.behind)
    kept, = settled_objects([wide], pan["frame"], [pan["prev"]], [-1.0], (H, W))
    assert abs(kept.velocity[0] - NEAR) <= 2.0
    # Its core is now what the neighbour showed alike: the pole's pixels, and of the
    # background beside it only what matched by chance.
    pole = set(zip(obj.rows.tolist(), obj.cols.tolist(), strict=True))
    core = set(zip(kept.rows.tolist(), kept.cols.tolist(), strict=True))
    assert pole <= core and len(core - pole) <= obj.rows.size // 2
    assert np.all(np.diff(kept.rows) >= 0)


def _banded(obj: EdgeObject, shifts: tuple[int, ...]) -> EdgeObject:
    """The object's core with copies of it ``shifts`` columns to the left (background)."""
    rows = np.concatenate([obj.rows] * len(shifts))
    cols = np.concatenate([obj.cols - s for s in shifts])
    order = np.argsort(rows, kind="stable")
    return EdgeObject(obj.side, rows[order], cols[order], obj.velocity, obj.behind)


def test_settled_objects_count_only_what_the_background_motion_does_not_explain():
    """A core three quarters background (as a clip's last frame, one neighbour, showed:
    half of it held at the pole's velocity, the background beside the pole matching its
    own velocity) keeps the pole: only the pixels the background's motion does not carry
    onto alike ones count."""
    pan = _pan()
    obj = edge_objects(pan["field"], 1.0, REF)[0]
    kept, = settled_objects([_banded(obj, (0, 8, 12, 16))], pan["frame"], [pan["prev"]],
                            [-1.0], (H, W))
    assert abs(kept.velocity[0] - NEAR) <= 2.0
    pole = set(zip(obj.rows.tolist(), obj.cols.tolist(), strict=True))
    assert pole <= set(zip(kept.rows.tolist(), kept.cols.tolist(), strict=True))


def test_covered_finds_the_pixels_read_where_the_neighbour_shows_the_object():
    """The object was found in neighbour 0 at columns 40-44 of rows 10-12; of the strip's
    other pixels, those reading neighbour 0 within a pixel of that span on their row read
    the object (which covers there the background they look for); reading neighbour 1,
    another row or further off, not."""
    rows = np.repeat([10.0, 11.0, 12.0], 5)
    taken = [(np.arange(15), 0, np.tile(np.arange(40.0, 45.0), 3), rows)]
    #                     in span, 0.9 past, 2.5 past, other row, other neighbour
    nx = np.array([0.0] * 15 + [42.0, 44.9, 46.5, 42.0, 42.0])
    ny = np.array([0.0] * 15 + [11.2, 10.0, 12.0, 20.0, 11.0])
    ks = np.array([0] * 15 + [0, 0, 0, 0, 1])
    cand = np.arange(15, 20)
    (i, idx), = [c for c in _covered(taken, cand, ks, nx, ny, 30) if c[0] == 0]
    assert i == 0 and idx.tolist() == [15, 16]


def test_overtaken_refuses_the_object_where_its_own_motion_finds_background():
    """A neighbour shows sky (75) and a white pole (250) over columns 20-25, its edge
    blurred (225 at 26). A background sample on the pole, or on its blurred edge, whose
    place under the pole's own motion shows sky is refused: the pole overtook the
    background there. Not where the pole's motion finds the pole too (within two pixels:
    its velocity is unsure), not a sample of sky, not where that motion leaves the frame."""
    plane = np.full((10, 80), 75.0, np.float32)
    plane[:, 20:26] = 250.0
    plane[:, 26] = 225.0
    look = np.array([250.0], np.float32)
    #                 pole, edge, pole (found), pole (2 px off), sky, pole (left frame)
    nx = np.array([22.0, 26.0, 22.0, 22.0, 40.0, 22.0])
    lx = np.array([40.0, 40.0, 24.0, 27.9, 60.0, -3.0])
    ny = ly = np.full(6, 5.0)
    got = _overtaken(plane, look, nx, ny, lx, ly, (1.0, 1.0), 80)
    assert got.tolist() == [True, True, False, False, False, False]


def test_objects_beyond_leaves_the_parts_alone_when_the_object_covers_none_of_them():
    """An object whose motion carries no strip pixel beyond its side takes none, and a
    neighbour that shows nothing unlike it refuses none: the parts come back as given."""
    plane = np.zeros((20, 40), np.float32)
    obj = EdgeObject(-1, np.arange(5, 15), np.full(10, 3), (0.0, 0.0), (0.0, 0.0))
    parts = [(0, np.array([5, 6]), np.array([0, 1]), np.array([10.0, 11.0]),
              np.array([5.0, 6.0]))]
    out, decided = objects_beyond(parts, [obj], (20, 40), 1.0, 9.5, [1.0], [1], plane,
                                  [plane])
    assert decided is None and len(out) == 1
    assert all(np.array_equal(a, b) for a, b in zip(out[0], parts[0], strict=True))


def test_a_pole_entering_below_a_black_wall_is_carried_beyond_the_edge_whole():
    # The astronaut 15 %/1.0 clip of benchmarks/edges.py: in frame 2 a dark pole enters
    # at the left below the black helmet. The field gave the pole's velocity to the
    # helmet above it, whose black was taken for the pole's look: the pole's top, which
    # the next frame saw, was missing (4 % of it shown).
    from skimage import data

    from unjello.pipeline import correct_frames

    from ...clips import pole_pan

    sim, _ = pole_pan(data.astronaut(), 0.15, 1.0)
    out, _ = correct_frames([s.rolling for s in sim], SensorTiming(1.0))
    dark = np.array([40.0, 40.0, 40.0])
    truth = np.abs(sim[2].truth.astype(np.int16) - dark).max(axis=-1) <= 12
    cols = np.flatnonzero(truth.mean(axis=0) >= 0.98)
    assert cols.size and cols[0] < 30  # the pole, near the left side
    top = np.abs(out[2][8:40, cols[0]:cols[-1] + 1].astype(np.int16) - dark).max(axis=-1)
    assert (top <= 12).mean() > 0.9


def test_background_a_pole_covers_in_the_previous_frame_is_read_two_frames_back():
    # The astronaut 25 %/1.0 clip of benchmarks/edges.py, frame 3: the pole leaving at the
    # right, 1.3x as fast as the pan, covers in frame 2 the background beside it that the
    # strip beyond the edge looks for (left as warped: 14.4 dB; now 21.7); frame 1 shows it.
    from skimage import data

    from unjello.pipeline import correct_frames
    from unjello.warp.maps import frame_maps

    from ...clips import pole_pan

    sim, _ = pole_pan(data.astronaut(), 0.25, 1.0)
    sim = sim[:5]
    out, _ = correct_frames([s.rolling for s in sim], SensorTiming(1.0))
    h, w = out[3].shape[:2]
    (mx, _), _ = frame_maps(sim[3].motion, h, w)
    strip = (mx > w - 0.5) & (np.arange(h) > h / 2)[:, None]  # the previous frame saw it
    err = out[3].astype(np.float64)[strip] - sim[3].truth[strip]
    assert strip.sum() > 1500
    assert 10 * np.log10(255.0 ** 2 / np.mean(err ** 2)) > 20.0
