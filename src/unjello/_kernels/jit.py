"""The compiler of the per-pixel kernels: Numba's ``njit``, cached where it can be."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from numba import njit

__all__ = ["compiled"]


def compiled(fn: Callable[..., Any]) -> Any:
    """``njit(cache=True, nogil=True)``; where no cache directory is writable, every run.

    A kernel releases the GIL: the threads measuring the next frames' flows run on
    while the main thread is in one (1080p default, timed whole: CPU 0.988x, wall 0.986x,
    ``docs/history/measurements.md``). Numba keys its cache on the kernel's source file, not on
    these options: a cache written by an older build of the same files is only replaced
    once they change (a new install does; in a working tree, delete ``__pycache__``).
    """
    try:
        return njit(cache=True, nogil=True)(fn)
    except RuntimeError:  # Numba found no writable cache directory
        return njit(nogil=True)(fn)
