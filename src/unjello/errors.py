"""Exceptions raised by unjello.

Every error the library raises on purpose derives from :class:`UnjelloError`, and
also from the builtin exception it is closest to, so callers may catch either.
The command line turns any :class:`UnjelloError` into one line on stderr and a
non-zero exit code.
"""

from __future__ import annotations

import errno
import os
from pathlib import Path

__all__ = [
    "UnjelloError",
    "InputError",
    "OutputError",
    "SettingsError",
    "MissingExtraError",
    "cannot_write",
]


class UnjelloError(Exception):
    """Base class of every error unjello raises deliberately."""


class InputError(UnjelloError, ValueError):
    """The input is missing, unreadable, or not something unjello can process."""


class OutputError(UnjelloError, OSError):
    """The output cannot be written (exists without overwrite, equals input, ...)."""


class SettingsError(UnjelloError, ValueError):
    """An option has an invalid value (readout out of range, unknown direction, ...)."""


class MissingExtraError(UnjelloError, ImportError):
    """An optional dependency is needed; the message says which ``pip install`` fixes it."""


def cannot_write(path: str | os.PathLike, exc: OSError) -> OutputError:
    """Say in one line why ``path`` could not be written, in the file system's terms."""
    folder = Path(path).parent
    why = {errno.EACCES: f"the folder {folder} is not writable",
           errno.EPERM: f"the folder {folder} is not writable",
           errno.EROFS: f"the folder {folder} is on a read-only file system",
           errno.ENOSPC: f"no space left on the device of {folder}",
           errno.EDQUOT: f"the disk quota of {folder} is exhausted",
           errno.ENOENT: f"the folder {folder} does not exist",
           errno.ENOTDIR: f"{folder} is not a folder"}.get(exc.errno or 0,
                                                           exc.strerror or str(exc))
    name = Path(path).name
    if name.startswith(".") and ".unjello-" in name:  # our temporary name: not the user's
        return OutputError(f"cannot write the output: {why}")
    return OutputError(f"cannot write {path}: {why}")
