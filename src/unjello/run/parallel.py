"""Every core on one clip: a thread pool for frame-level work.

Frame pairs' flows are independent, so they are measured ahead on a pool of threads
(OpenCV releases the GIL) while the main thread solves, warps and encodes the frames
before them. Parallel work *between* frames is cheaper than OpenCV's own threads
*within* each call: on small working copies its pool spends a third of the CPU time
handing work out and waiting (1080p default on 2 cores: 161 against 117 core-ms a frame
for the correction stage, ``docs/history/measurements.md``), so OpenCV runs single-threaded
while the pool is up, and is given back its thread count afterwards.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager

import cv2

__all__ = ["cores", "frame_threads"]


def cores() -> int:
    """Return the number of CPU cores this process may run on (``taskset`` respected)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # macOS, Windows
        return os.cpu_count() or 1


@contextmanager
def frame_threads(workers: int = 0) -> Iterator[ThreadPoolExecutor | None]:
    """Open a pool of ``workers`` threads for the flows; OpenCV single-threaded meanwhile.

    Parameters
    ----------
    workers : int
        Threads (0: one per core, :func:`cores`). With one there is no pool: the work is
        done in the calling thread, and OpenCV still runs single-threaded.

    Yields
    ------
    ThreadPoolExecutor or None
    """
    workers = workers or cores()
    before = cv2.getNumThreads()
    cv2.setNumThreads(1)
    pool = ThreadPoolExecutor(workers, thread_name_prefix="unjello") if workers > 1 else None
    try:
        yield pool
    finally:
        if pool is not None:
            pool.shutdown(wait=True, cancel_futures=True)
        cv2.setNumThreads(before)
