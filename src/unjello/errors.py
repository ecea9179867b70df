"""Exceptions raised by unjello.

Every error the library raises on purpose derives from :class:`UnjelloError`, and
also from the builtin exception it is closest to, so callers may catch either.
The command line turns any :class:`UnjelloError` into one line on stderr and a
non-zero exit code.
"""

from __future__ import annotations

__all__ = [
    "UnjelloError",
    "InputError",
    "OutputError",
    "SettingsError",
    "MissingExtraError",
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
