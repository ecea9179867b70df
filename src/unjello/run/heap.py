"""Give memory the process freed back to the operating system, when it holds much of it.

glibc keeps the memory a process frees for its next allocations. A correction frees
large arrays every frame (planes, maps, fields) in a changing order, and the freed pieces
between live ones add up: at 4K the process held 115-130 MiB it did not use (peak
resident 2227 against 2123 MiB with a trim every ten pictures, the simulated 3840 x 2160
speed clip, 60 frames). ``malloc_trim`` returns them. At 1080p they come to about 75 MiB,
which the next frames use again: trimming them too made those frames fault the memory in
again, 1-3 % of the whole run's CPU (``docs/history/measurements.md``). So the heap is trimmed
only while it holds more than :data:`HELD_MAX` freed. Elsewhere than glibc it is a
no-op. Called as pictures are written: by a whole run (:mod:`unjello.pipeline`) and by
each segment of a long clip on a cluster (:mod:`unjello.run.segments`).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import sys
from collections.abc import Callable

__all__ = ["HELD_MAX", "TRIM_EVERY", "held", "trim"]

#: Pictures written between trims of the heap: a trim's memory is faulted in again (at 4K,
#: every picture +2 s of system time over 60 frames, every ten +0.1 s).
TRIM_EVERY = 10

#: Freed memory (bytes) the process keeps for its next allocations; above it, a trim.
HELD_MAX = 100 * 2**20


class _Mallinfo2(ctypes.Structure):
    """glibc's ``struct mallinfo2`` (2.33 and later): the heap's counters, in bytes."""

    _fields_ = [(name, ctypes.c_size_t) for name in (
        "arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks", "fsmblks", "uordblks",
        "fordblks", "keepcost")]


@functools.cache
def _libc() -> ctypes.CDLL | None:
    if not sys.platform.startswith("linux"):
        return None
    try:
        return ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
    except OSError:
        return None


@functools.cache
def _malloc_trim() -> Callable[[int], int] | None:
    libc = _libc()
    return getattr(libc, "malloc_trim", None)  # None: not glibc (musl has none)


@functools.cache
def _mallinfo2() -> Callable[[], _Mallinfo2] | None:
    fn = getattr(_libc(), "mallinfo2", None)  # None: glibc older than 2.33
    if fn is not None:
        fn.restype = _Mallinfo2
    return fn


def held() -> int | None:
    """Freed memory (bytes) the allocator keeps in its arenas; None where it cannot say."""
    fn = _mallinfo2()
    return None if fn is None else int(fn().fordblks)


def trim(written: int) -> bool:
    """Trim the heap if it holds over :data:`HELD_MAX` freed, every :data:`TRIM_EVERY` pictures.

    Where the allocator cannot say what it holds (glibc before 2.33), every
    :data:`TRIM_EVERY` pictures.

    Returns
    -------
    bool
        Whether memory was given back (glibc says so).
    """
    fn = _malloc_trim()
    if fn is None or written % TRIM_EVERY:
        return False
    kept = held()
    if kept is not None and kept <= HELD_MAX:
        return False
    return bool(fn(0))
