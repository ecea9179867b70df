"""Files beside a clip: stated readouts, gyro logs found, read and written."""

import json

import av
import numpy as np
import pytest

from unjello.config import CorrectionConfig
from unjello.errors import InputError, SettingsError
from unjello.io.sidecars import find_gyro_log, read_gyro, stated_readout, write_gyro
from unjello.pipeline import correct_video

from ..clips import make_clip


def test_stated_readout_sidecar_and_metadata(tmp_path, scene):
    clip = tmp_path / "clip.mp4"
    make_clip(clip, scene, n=4, audio=False)
    assert stated_readout(clip) is None
    # A Gyroflow lens profile beside the clip states the readout in ms.
    (tmp_path / "clip.json").write_text(json.dumps(
        {"camera_brand": "Test", "frame_readout_time": 25.0, "calib_dimension": {}}))
    st = stated_readout(clip)
    assert st is not None and st.milliseconds == 25.0 and "clip.json" in st.source
    messages = []
    traj = correct_video(clip, tmp_path / "o.mp4", log=messages.append)
    assert traj.timing.readout == pytest.approx(0.75, abs=1e-3)  # 25 ms at 30 fps
    assert "sidecar" in messages[0]
    # The command line wins.
    traj = correct_video(clip, tmp_path / "o2.mp4", CorrectionConfig(readout=0.5))
    assert traj.timing.readout == 0.5
    # A container tag (Matroska keeps free-form tags).
    mkv = tmp_path / "tagged.mkv"
    with av.open(str(clip)) as src, av.open(str(mkv), "w") as out:
        out.metadata["READOUT_MS"] = "12.5"
        vs = out.add_stream_from_template(src.streams.video[0])
        for p in src.demux(src.streams.video[0]):
            if p.dts is not None:
                p.stream = vs
                out.mux(p)
    st = stated_readout(mkv)
    assert st is not None and st.milliseconds == 12.5 and st.source == "container metadata"


def test_read_gyro_finds_the_time_column_and_its_unit(tmp_path):
    t = np.arange(50) * 2.5 + 1000.0  # ms, 400 Hz
    rates = np.random.default_rng(0).normal(0, 0.1, (50, 3))
    p = tmp_path / "g.csv"
    lines = ["# a comment", "wx,wy,wz,t"] + [f"{a},{b},{c},{d}" for (a, b, c), d in
                                             zip(rates, t, strict=True)]
    p.write_text("\n".join(lines))
    log = read_gyro(p)
    assert np.allclose(log.time, t / 1000) and np.allclose(log.rate, rates)
    q = tmp_path / "g.txt"  # time first, seconds, degrees, spaces
    q.write_text("\n".join(f"{d / 1000} {a} {b} {c}" for (a, b, c), d in
                           zip(np.rad2deg(rates), t, strict=True)))
    log2 = read_gyro(q, layout="t,x,y,z", units="deg")
    assert np.allclose(log2.time, log.time) and np.allclose(log2.rate, rates)


def test_read_gyro_refuses_what_is_not_a_log(tmp_path):
    p = tmp_path / "notes.txt"
    p.write_text("hello\nworld\n")
    with pytest.raises(InputError, match="not a gyro log"):
        read_gyro(p)
    with pytest.raises(InputError, match="cannot read"):
        read_gyro(tmp_path / "missing.csv")


def test_write_gyro_is_what_read_gyro_reads(tmp_path):
    t = np.linspace(0.0, 1.0, 401)
    rates = np.stack([np.sin(t), np.cos(t), t], axis=1)
    write_gyro(tmp_path / "g.csv", t, rates)
    assert (tmp_path / "g.csv").read_text().startswith("t,x,y,z\n")
    log = read_gyro(tmp_path / "g.csv")
    assert np.allclose(log.time, t) and np.allclose(log.rate, rates, atol=1e-8)


def test_find_gyro_log_beside_a_clip_or_a_folder(tmp_path):
    clip = tmp_path / "run.mp4"
    clip.write_bytes(b"")
    with pytest.raises(SettingsError, match="pass gyro=FILE or put run.gyro.csv beside run.mp4"):
        find_gyro_log(clip)
    (tmp_path / "run.gyro.txt").write_text("")
    assert find_gyro_log(clip) == tmp_path / "run.gyro.txt"
    (tmp_path / "run.gyro.csv").write_text("")
    assert find_gyro_log(clip) == tmp_path / "run.gyro.csv"  # CSV first
    frames = tmp_path / "shots"
    frames.mkdir()
    (tmp_path / "shots.gyro.csv").write_text("")
    assert find_gyro_log(frames) == tmp_path / "shots.gyro.csv"
