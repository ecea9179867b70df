"""Give memory the process freed back to the operating system, every few pictures.

glibc keeps the memory a process frees for its next allocations. A correction frees
large arrays every frame (planes, maps, fields) in a changing order, and the freed pieces
between live ones add up: at 4K the process held about 100 MB more than it used (peak
resident 2227 against 2123 MiB with the trim every ten pictures, the simulated 3840 x 2160
speed clip, 60 frames). ``malloc_trim`` returns them. Elsewhere than glibc it is a no-op.
Called as pictures are written: by a whole run (:mod:`unjello.pipeline`) and by each
segment of a long clip on a cluster (:mod:`unjello.segments`).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import sys
from collections.abc import Callable

__all__ = ["TRIM_EVERY", "trim"]

#: Pictures written between trims: each costs a walk over the heap, and the memory it
#: returns is faulted in again when next used (at 4K, every picture: +2 s of system time
#: over 60 frames; every ten: +0.1 s).
TRIM_EVERY = 10


@functools.cache
def _malloc_trim() -> Callable[[int], int] | None:
    if not sys.platform.startswith("linux"):
        return None
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        return libc.malloc_trim  # type: ignore[no-any-return]
    except (OSError, AttributeError):  # not glibc (musl has no malloc_trim)
        return None


def trim(written: int) -> bool:
    """Trim the heap when ``written`` pictures make a multiple of :data:`TRIM_EVERY`.

    Returns
    -------
    bool
        Whether memory was given back (glibc says so).
    """
    fn = _malloc_trim()
    if fn is None or written % TRIM_EVERY:
        return False
    return bool(fn(0))
