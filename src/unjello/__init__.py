"""unjello: remove rolling-shutter distortion (skew, wobble, jello) from video.

The public surface is declared once, here. Typical use::

    import unjello
    unjello.correct_video("in.mp4", "out.mp4", unjello.CorrectionConfig(readout="36ms"))
    config = unjello.CorrectionConfig.from_preset("drone")
    frames, trajectory = unjello.correct_frames(list_of_arrays, unjello.SensorTiming(0.9))

See :mod:`unjello.timing` for the conventions of time, geometry and sign.
"""

from __future__ import annotations

import importlib
import sys
import types
from typing import TYPE_CHECKING

__version__ = "0.1.0"

if TYPE_CHECKING:
    from .clip import ResolvedTiming, resolve_timing
    from .config import CorrectionConfig
    from .errors import InputError, MissingExtraError, OutputError, SettingsError, UnjelloError
    from .gyrolog import GyroConfig, GyroLog
    from .io.sidecars import read_gyro, write_gyro
    from .io.video import EncodeOptions
    from .metrics import evaluate
    from .motion.dense.method import DenseConfig, DenseMethod
    from .motion.gyro.method import GyroMethod
    from .motion.paper.global_motion import BlockMatchConfig
    from .motion.paper.method import PaperConfig, PaperMethod
    from .motion.paper.refine import RefineConfig
    from .pipeline import Corrector, correct_frames, correct_video
    from .readout.flicker import readout_from_flicker
    from .readout.footage import ReadoutEstimate, estimate_readout, estimate_readout_file
    from .run.batch import run_batch
    from .simulate import Motion, gyro_samples, simulate, simulate_clip
    from .timing import SensorTiming, parse_readout
    from .trajectory import FrameMotion, Trajectory

#: Each public name and the module it lives in, imported on first use (the imports above
#: are for type checkers only; ``__all__`` below stays a literal list for them too).
_WHERE = {
    "run_batch": ".run.batch",
    "ResolvedTiming": ".clip",
    "resolve_timing": ".clip",
    "CorrectionConfig": ".config",
    "InputError": ".errors",
    "MissingExtraError": ".errors",
    "OutputError": ".errors",
    "SettingsError": ".errors",
    "UnjelloError": ".errors",
    "GyroConfig": ".gyrolog",
    "GyroLog": ".gyrolog",
    "read_gyro": ".io.sidecars",
    "write_gyro": ".io.sidecars",
    "EncodeOptions": ".io.video",
    "evaluate": ".metrics",
    "DenseConfig": ".motion.dense.method",
    "DenseMethod": ".motion.dense.method",
    "BlockMatchConfig": ".motion.paper.global_motion",
    "GyroMethod": ".motion.gyro.method",
    "PaperConfig": ".motion.paper.method",
    "PaperMethod": ".motion.paper.method",
    "RefineConfig": ".motion.paper.refine",
    "Corrector": ".pipeline",
    "correct_frames": ".pipeline",
    "correct_video": ".pipeline",
    "ReadoutEstimate": ".readout.footage",
    "estimate_readout": ".readout.footage",
    "estimate_readout_file": ".readout.footage",
    "readout_from_flicker": ".readout.flicker",
    "Motion": ".simulate",
    "gyro_samples": ".simulate",
    "simulate": ".simulate",
    "simulate_clip": ".simulate",
    "SensorTiming": ".timing",
    "parse_readout": ".timing",
    "FrameMotion": ".trajectory",
    "Trajectory": ".trajectory",
}

__all__ = [
    "__version__",
    "BlockMatchConfig",
    "CorrectionConfig",
    "Corrector",
    "DenseConfig",
    "DenseMethod",
    "EncodeOptions",
    "FrameMotion",
    "GyroConfig",
    "GyroLog",
    "GyroMethod",
    "InputError",
    "MissingExtraError",
    "Motion",
    "OutputError",
    "PaperConfig",
    "PaperMethod",
    "ReadoutEstimate",
    "RefineConfig",
    "ResolvedTiming",
    "SensorTiming",
    "SettingsError",
    "Trajectory",
    "UnjelloError",
    "correct_frames",
    "gyro_samples",
    "read_gyro",
    "write_gyro",
    "correct_video",
    "estimate_readout",
    "estimate_readout_file",
    "evaluate",
    "parse_readout",
    "readout_from_flicker",
    "resolve_timing",
    "run_batch",
    "simulate",
    "simulate_clip",
]


def __getattr__(name: str) -> object:
    """Import a public name's module on first use (PEP 562).

    ``import unjello`` then costs what it uses: the command line can still choose how
    many threads NumPy's BLAS starts (:mod:`unjello.__main__`) before anything imports NumPy.
    """
    where = _WHERE.get(name)
    if where is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(where, __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)


class _Package(types.ModuleType):
    """The package's module: a subpackage imported later does not shadow a public name."""

    def __setattr__(self, name: str, value: object) -> None:
        # The import system sets a subpackage as its parent's attribute: ``unjello.simulate``
        # stays the function, as it was when this file imported every name at once.
        if isinstance(value, types.ModuleType) and name in _WHERE:
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
