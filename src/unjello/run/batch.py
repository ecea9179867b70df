"""Batches: many clips through `correct`, on a local process pool, Dask or Ray.

All three run the same job function through one stdlib
:class:`concurrent.futures.Executor` interface: a :class:`~concurrent.futures.ProcessPoolExecutor`
sized to the cores (``local``), a Dask ``Client.get_executor()`` (``dask``, on an existing
cluster with ``address`` or a local one), or Ray tasks whose ``ObjectRef.future()`` are
the futures (``ray``). Dask and Ray are optional extras.

A batch is resumable: an output that exists is skipped unless ``overwrite``; each output
is written atomically by :func:`unjello.pipeline.correct_video`; one JSON line per clip
(status, seconds, readout used, error) is appended to the report as results arrive, and
a failing clip never stops the others.
"""

from __future__ import annotations

import concurrent.futures as cf
import glob
import json
import multiprocessing
import os
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from ..config import CorrectionConfig
from ..errors import InputError, MissingExtraError, SettingsError, UnjelloError
from ..io.frames import IMAGE_SUFFIXES
from ..io.video import VIDEO_SUFFIXES

__all__ = ["expand_inputs", "output_for", "run_job", "executor", "run_batch", "EXECUTORS"]

EXECUTORS = ("local", "dask", "ray")


def expand_inputs(inputs: Sequence[str | os.PathLike]) -> list[Path]:
    """Turn files, folders and glob patterns into a sorted list of clips.

    A folder holding videos contributes each video; a folder holding only images is one
    clip (a frame sequence).

    Raises
    ------
    InputError
        If nothing matches.
    """
    out: list[Path] = []
    for item in inputs:
        text = str(item)
        matches = [Path(m) for m in sorted(glob.glob(text))] if any(
            ch in text for ch in "*?[") else [Path(text)]
        for p in matches:
            if p.is_dir():
                videos = sorted(q for q in p.iterdir()
                                if q.is_file() and q.suffix.lower() in VIDEO_SUFFIXES)
                if videos:
                    out.extend(videos)
                elif any(q.suffix.lower() in IMAGE_SUFFIXES for q in p.iterdir()):
                    out.append(p)
            else:
                out.append(p)
    if not out:
        raise InputError(f"no clips found in {', '.join(map(str, inputs))}")
    seen: set[Path] = set()
    return [p for p in out if not (p in seen or seen.add(p))]  # type: ignore[func-returns-value]


def output_for(src: Path, out_dir: Path) -> Path:
    """Output path of a clip: same name in ``out_dir`` (a folder stays a folder)."""
    return out_dir / src.name


def run_job(src: str, dst: str, config: CorrectionConfig, overwrite: bool) -> dict[str, Any]:
    """Correct one clip; never raises for a bad clip (the error goes into the result).

    Returns
    -------
    dict
        ``input``, ``output``, ``status`` (ok, skipped, failed), ``seconds``, ``frames``,
        ``readout``, ``error``, ``warnings`` (what ``correct`` would say,
        :meth:`unjello.summary.RunSummary.warnings`).
    """
    from ..pipeline import correct_video
    from ..summary import summarize

    t0 = time.perf_counter()
    row: dict[str, Any] = {"input": src, "output": dst, "status": "ok", "seconds": 0.0,
                           "frames": 0, "readout": None, "error": None, "warnings": []}
    if Path(dst).exists() and not overwrite:
        row["status"] = "skipped"
        return row
    try:
        traj = correct_video(src, dst, config, overwrite=overwrite)
        row["frames"] = len(traj)
        row["readout"] = traj.timing.readout
        stab = config.stabilize
        row["warnings"] = summarize(
            traj, (stab.smoothness, stab.crop) if stab.enabled else None).warnings()
    except UnjelloError as exc:
        row["status"], row["error"] = "failed", str(exc)
    except Exception as exc:  # noqa: BLE001 - one bad clip must not stop a batch
        row["status"], row["error"] = "failed", f"{exc.__class__.__name__}: {exc}"
    row["seconds"] = round(time.perf_counter() - t0, 3)
    return row


class _RayExecutor(cf.Executor):
    """Ray tasks behind the stdlib Executor interface (``ObjectRef.future()``)."""

    def __init__(self, ray: Any) -> None:
        self._ray = ray
        self._remote: dict[Callable, Any] = {}

    def submit(self, fn: Callable, /, *args: Any, **kwargs: Any) -> cf.Future:
        if fn not in self._remote:
            self._remote[fn] = self._ray.remote(fn)
        return self._remote[fn].remote(*args, **kwargs).future()


@contextmanager
def executor(kind: str = "local", address: str | None = None,
             workers: int | None = None) -> Iterator[cf.Executor]:
    """Open an executor of ``kind`` (local, dask, ray); close it on exit.

    Parameters
    ----------
    kind : {'local', 'dask', 'ray'}
    address : str, optional
        Scheduler (``tcp://host:8786``) or Ray (``ray://host:10001`` / ``auto``) address;
        default: start a local cluster.
    workers : int, optional
        Worker processes of a local pool or local cluster (default: the cores).

    Raises
    ------
    MissingExtraError
        If Dask or Ray is not installed.
    """
    n = workers or os.cpu_count() or 1
    if kind == "local":
        # Started fresh, not forked: a fork of a process whose OpenCV threads have run
        # inherits their locks held, and hangs in its first OpenCV call.
        with cf.ProcessPoolExecutor(max_workers=n,
                                    mp_context=multiprocessing.get_context("spawn")) as pool:
            yield pool
    elif kind == "dask":
        try:
            from distributed import Client, LocalCluster
        except ImportError:
            raise MissingExtraError("the dask executor needs Dask: pip install "
                                    "'unjello[dask]'") from None
        cluster = None if address else LocalCluster(n_workers=n, threads_per_worker=1,
                                                    processes=True, dashboard_address=None)
        client = Client(address or cluster)
        try:
            yield client.get_executor()
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
    elif kind == "ray":
        try:
            import ray
        except ImportError:
            raise MissingExtraError("the ray executor needs Ray: pip install "
                                    "'unjello[ray]'") from None
        started = not ray.is_initialized()
        if started:
            if address:
                ray.init(address=address, log_to_driver=False)
            else:
                ray.init(num_cpus=n, include_dashboard=False, log_to_driver=False)
        try:
            yield _RayExecutor(ray)
        finally:
            if started:
                ray.shutdown()
    else:
        raise SettingsError(f"executor must be one of {', '.join(EXECUTORS)}")


def run_batch(inputs: Sequence[str | os.PathLike], out_dir: str | os.PathLike, *,
              kind: str = "local", address: str | None = None, workers: int | None = None,
              overwrite: bool = False, report: str | os.PathLike | None = None,
              config: CorrectionConfig | None = None,
              on_result: Callable[[dict[str, Any]], None] | None = None) -> list[dict[str, Any]]:
    """Correct many clips into ``out_dir``.

    Parameters
    ----------
    inputs : sequence of path-like or str
        Files, folders, globs (see :func:`expand_inputs`).
    out_dir : path-like
        Output folder (created if missing).
    kind, address, workers : see :func:`executor`.
    overwrite : bool
        Redo clips whose output exists.
    report : path-like, optional
        JSON-lines report (default ``out_dir/unjello-batch.jsonl``), appended to.
    config : CorrectionConfig, optional
        The settings of every clip (:func:`unjello.pipeline.correct_video`).
    on_result : callable, optional
        Called with each clip's result as it arrives.

    Returns
    -------
    list of dict
        One result per clip (see :func:`run_job`), in input order.
    """
    clips = expand_inputs(inputs)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    report_path = Path(report) if report else out / "unjello-batch.jsonl"
    config = config or CorrectionConfig()
    results: dict[int, dict[str, Any]] = {}
    with executor(kind, address, workers) as ex, report_path.open("a") as rep:
        futures = {ex.submit(run_job, str(c), str(output_for(c, out)), config, overwrite): i
                   for i, c in enumerate(clips)}
        for fut in cf.as_completed(futures):
            i = futures[fut]
            try:
                row = fut.result()
            except Exception as exc:  # noqa: BLE001 - a lost worker fails one clip
                row = {"input": str(clips[i]), "output": str(output_for(clips[i], out)),
                       "status": "failed", "seconds": 0.0, "frames": 0, "readout": None,
                       "error": f"{exc.__class__.__name__}: {exc}"}
            results[i] = row
            rep.write(json.dumps(row) + "\n")
            rep.flush()
            if on_result:
                on_result(row)
    return [results[i] for i in range(len(clips))]
