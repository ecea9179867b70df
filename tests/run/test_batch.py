import json

import pytest

from unjello.errors import InputError
from unjello.run.batch import expand_inputs, run_batch

from ..clips import make_clip
from ..runner import run_process as run


@pytest.fixture(scope="module")
def clips(tmp_path_factory, scene):
    d = tmp_path_factory.mktemp("clips")
    for i in range(3):
        make_clip(d / f"clip{i}.mp4", scene, n=4, size=(128, 96), audio=False, speed=4 + i)
    (d / "broken.mp4").write_text("not a video")
    return d


def test_expand_inputs(clips, tmp_path):
    found = expand_inputs([clips])
    assert [p.name for p in found] == ["broken.mp4", "clip0.mp4", "clip1.mp4", "clip2.mp4"]
    assert len(expand_inputs([str(clips / "clip*.mp4")])) == 3
    with pytest.raises(InputError):
        expand_inputs([str(tmp_path / "*.mp4")])


@pytest.mark.slow
def test_local_batch_resumable_and_reports_failures(clips, tmp_path):
    out = tmp_path / "out"
    rows = run_batch([clips], out, kind="local", workers=2)
    status = {r["input"].rsplit("/", 1)[1]: r["status"] for r in rows}
    assert status == {"broken.mp4": "failed", "clip0.mp4": "ok", "clip1.mp4": "ok",
                      "clip2.mp4": "ok"}
    assert sorted(p.name for p in out.glob("*.mp4")) == ["clip0.mp4", "clip1.mp4",
                                                         "clip2.mp4"]
    lines = [json.loads(x) for x in (out / "unjello-batch.jsonl").read_text().splitlines()]
    assert len(lines) == 4 and all("seconds" in x and "readout" in x for x in lines)
    again = run_batch([clips], out, kind="local", workers=2)
    assert sorted(r["status"] for r in again) == ["failed", "skipped", "skipped", "skipped"]


@pytest.mark.slow
def test_dask_batch(clips, tmp_path):
    pytest.importorskip("distributed")
    rows = run_batch([str(clips / "clip*.mp4")], tmp_path / "out", kind="dask", workers=2)
    assert [r["status"] for r in rows] == ["ok", "ok", "ok"]


@pytest.mark.slow
def test_ray_batch(clips, tmp_path):
    pytest.importorskip("ray")
    rows = run_batch([str(clips / "clip0.mp4")], tmp_path / "out", kind="ray", workers=1)
    assert [r["status"] for r in rows] == ["ok"]


@pytest.mark.slow
def test_batch_cli_exit_code(clips, tmp_path):
    res = run("batch", clips, "-o", tmp_path / "out", "--workers", "2", "--preset", "fast")
    assert res.returncode == 1
    assert "3 corrected, 0 skipped, 1 failed" in res.stderr
    assert "Traceback" not in res.stderr


@pytest.mark.slow
def test_batch_with_the_gyro_method_finds_each_clips_log(tmp_path, scene):
    """`batch --method gyro`: a clip with NAME.gyro.csv beside it is corrected, one
    without is reported as failed, with the fix in its message."""
    from unjello.simulate import Motion, gyro_samples

    src = tmp_path / "in"
    src.mkdir()
    for name in ("logged", "bare"):
        make_clip(src / f"{name}.mp4", scene, n=32, fps=25, size=(160, 120), audio=False)
    t, rates = gyro_samples(Motion("pan", fps=25.0, speed=6.0), 1280.0, 32 / 25)
    (src / "logged.gyro.csv").write_text("\n".join(
        f"{ti:.6f},{a:.7f},{b:.7f},{c:.7f}" for ti, (a, b, c) in zip(t, rates, strict=True)))
    res = run("batch", src, "-o", tmp_path / "out", "--method", "gyro")
    assert res.returncode == 1
    rows = {json.loads(x)["input"].rsplit("/", 1)[1]: json.loads(x) for x in
            (tmp_path / "out" / "unjello-batch.jsonl").read_text().splitlines()}
    assert rows["logged.mp4"]["status"] == "ok" and rows["logged.mp4"]["frames"] == 32
    assert rows["bare.mp4"]["status"] == "failed"
    assert "bare.gyro.csv" in rows["bare.mp4"]["error"]
