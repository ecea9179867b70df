"""The compiler of the per-pixel kernels: Numba's ``njit``, cached where it can be."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from numba import njit

__all__ = ["compiled"]


def compiled(fn: Callable[..., Any]) -> Any:
    """``njit(cache=True)``; where no cache directory is writable, compiled every run."""
    try:
        return njit(cache=True)(fn)
    except RuntimeError:  # Numba found no writable cache directory
        return njit(fn)
