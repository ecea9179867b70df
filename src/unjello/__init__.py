"""unjello: remove rolling-shutter distortion (skew, wobble, jello) from video.

The public surface is declared once, here. Typical use::

    import unjello
    unjello.correct_video("in.mp4", "out.mp4", unjello.CorrectionConfig(readout="36ms"))
    config = unjello.CorrectionConfig.from_preset("drone")
    frames, trajectory = unjello.correct_frames(list_of_arrays, unjello.SensorTiming(0.9))

See :mod:`unjello.timing` for the conventions of time, geometry and sign.
"""

from __future__ import annotations

__version__ = "0.1.0"

from .batch import run_batch
from .clip import ResolvedTiming, resolve_timing
from .config import CorrectionConfig
from .errors import InputError, MissingExtraError, OutputError, SettingsError, UnjelloError
from .gyrolog import GyroConfig, GyroLog
from .io.sidecars import read_gyro, write_gyro
from .io.video import EncodeOptions
from .metrics import evaluate
from .motion.dense import DenseConfig, DenseMethod
from .motion.global_motion import BlockMatchConfig
from .motion.gyro import GyroMethod
from .motion.paper import PaperConfig, PaperMethod
from .motion.refine import RefineConfig
from .pipeline import Corrector, correct_frames, correct_video
from .readout import ReadoutEstimate, estimate_readout, estimate_readout_file, readout_from_flicker
from .simulate import Motion, gyro_samples, simulate, simulate_clip
from .timing import SensorTiming, parse_readout
from .trajectory import FrameMotion, Trajectory

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
