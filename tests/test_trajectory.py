"""The Trajectory, the hub: eq. 26 per scanline, its JSON form, streaming writes."""

import dataclasses
import json

import numpy as np
import pytest

from unjello.errors import InputError
from unjello.timing import SensorTiming
from unjello.trajectory import FIELD_STEP, FrameMotion, Trajectory, TrajectoryWriter


def _traj(with_field=False):
    h, w = 24, 40
    frames = []
    for n in range(3):
        vel = np.tile([2.0 + n, -1.0], (h, 1))
        disp = np.cumsum(vel, axis=0) / h - vel[0] * 0.5
        fld = (np.dstack([np.full((h, w), 0.5 * n), np.linspace(0, 1, w)[None].repeat(h, 0)])
               .astype(np.float32) if with_field else None)
        frames.append(FrameMotion(n, float(n), disp, vel, ok=n != 1,
                                  note="bridged" if n == 1 else "", fallback=0.1 * n,
                                  entering=0.05 * n, folds=0.001 * n, field=fld))
    return Trajectory(SensorTiming(0.8, "left-right", "first"), (w, h), frames, "dense")


def test_json_round_trip_keeps_everything_the_schema_names(tmp_path):
    traj = _traj()
    traj.save(tmp_path / "m.json")
    doc = json.loads((tmp_path / "m.json").read_text())
    assert (doc["schema"], doc["version"], doc["method"]) == ("unjello.trajectory", 1, "dense")
    back = Trajectory.load(tmp_path / "m.json")
    assert back.timing == traj.timing and back.size == traj.size and len(back) == 3
    for a, b in zip(traj.frames, back.frames, strict=True):
        assert (a.index, a.start, a.ok, a.note) == (b.index, b.start, b.ok, b.note)
        assert a.fallback == pytest.approx(b.fallback) and a.folds == pytest.approx(b.folds)
        assert a.entering == pytest.approx(b.entering)
        assert np.allclose(a.displacement, b.displacement, atol=1e-4)
        assert np.allclose(a.velocity, b.velocity, atol=1e-4)


def test_a_field_is_stored_coarsely_and_read_back_smoothly(tmp_path):
    traj = _traj(with_field=True)
    traj.save(tmp_path / "m.json")
    doc = json.loads((tmp_path / "m.json").read_text())
    stored = np.asarray(doc["frames"][2]["field"])
    assert stored.shape == (24 // FIELD_STEP, 40 // FIELD_STEP, 2)
    back = Trajectory.load(tmp_path / "m.json").frames[2].pixel_displacement(40)
    assert back.shape == (24, 40, 2)
    err = np.abs(back - traj.frames[2].field)
    assert err[:, 4:-4].max() < 0.01 and err.max() < 0.1  # linear inside, held at the ends


def test_a_front_layer_is_stored_with_the_field_and_read_back(tmp_path):
    traj = _traj(with_field=True)
    h, w = 24, 40
    layer = np.zeros((h, w, 3), np.float32)
    layer[..., 0] = np.linspace(-2, 2, w)[None]  # a backward displacement
    layer[4:20, 8:32, 2] = 1.0  # the object's weight
    traj.frames[2] = dataclasses.replace(traj.frames[2], front=(layer,))
    traj.save(tmp_path / "m.json")
    doc = json.loads((tmp_path / "m.json").read_text())
    stored = doc["frames"][2]["front"][0]
    assert stored["shape"] == [h, w]
    assert np.asarray(stored["layer"]).shape == (h // FIELD_STEP, w // FIELD_STEP, 3)
    assert "front" not in doc["frames"][1]
    back = Trajectory.load(tmp_path / "m.json").frames[2].front
    assert len(back) == 1 and back[0].shape == (h, w, 3)
    assert np.abs(back[0][:, 4:-4, 0] - layer[:, 4:-4, 0]).max() < 0.01
    assert back[0][12, 20, 2] > 0.9 and back[0][0, 0, 2] < 0.5  # every 8 px: softened


def test_the_streaming_writer_writes_the_same_document(tmp_path):
    traj = _traj()
    traj.save(tmp_path / "a.json")
    writer = TrajectoryWriter(tmp_path / "b.json", Trajectory(traj.timing, traj.size,
                                                              method="dense"))
    for f in traj.frames:
        writer.write(f)
    assert not (tmp_path / "b.json").exists()  # only when complete
    writer.close()
    assert json.loads((tmp_path / "a.json").read_text()) == json.loads(
        (tmp_path / "b.json").read_text())
    aborted = TrajectoryWriter(tmp_path / "c.json", traj)
    aborted.write(traj.frames[0])
    aborted.abort()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.json", "b.json"]


@pytest.mark.parametrize("doc, message", [
    ({"frames": []}, "not an unjello trajectory"),
    ({"schema": "unjello.trajectory", "version": 99}, "newer than supported"),
])
def test_foreign_or_future_files_are_refused(tmp_path, doc, message):
    p = tmp_path / "m.json"
    p.write_text(json.dumps(doc))
    with pytest.raises(InputError, match=message):
        Trajectory.load(p)
    with pytest.raises(InputError, match="cannot read trajectory"):
        Trajectory.load(tmp_path / "missing.json")


def test_displacements_stack_per_frame():
    traj = _traj()
    assert traj.displacements().shape == (3, 24, 2)
    assert np.allclose(traj.displacements()[2], traj.frames[2].displacement)
