"""Settings: :class:`CorrectionConfig`, its options and presets (no file is read here).

Every knob a user can turn is one field of :class:`CorrectionConfig` (or of the method
settings it holds) and one :class:`Option` in :data:`OPTIONS`: its preset key, its flag
(``--name``, the CLI builds them from this table) and where it lives. Adding a knob takes
those two edits.

The sensor's timing -- readout, scan direction, reference line -- and the frame rate can
come from several places. :func:`unjello.clip.resolve_timing` decides them in one
documented order and records where each value came from:

1. a motion file applied with ``motion_in`` (its timing is the one it was made with);
2. the settings (in turn: the command line, a preset, Python);
3. what a sidecar file or the video's metadata states (readout only);
4. for ``readout="auto"``, the estimate from the footage's motion;
5. the defaults: readout 1.0 of the frame interval, top-bottom, middle line.

The frame rate is the ``fps`` setting if given, else the video's own; a folder of frames
states none, and 30 fps is assumed, which a readout in milliseconds refuses to rely on.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .errors import SettingsError
from .gyrolog import GyroConfig
from .io.video import EncodeOptions
from .motion.dense.config import DETAILS
from .motion.dense.method import DenseConfig
from .motion.paper.method import PaperConfig
from .stabilize import StabilizeConfig, crop_request
from .timing import (
    DIRECTIONS,
    REFERENCES,
    ClipSpan,
    ReadoutRequest,
    clip_time,
    readout_request,
)
from .warp.warper import FILLS, WARPS

__all__ = ["METHODS", "PRESETS", "OPTIONS", "Option", "CorrectionConfig", "FOLDER_FPS"]

METHODS = ("dense", "paper", "gyro")

#: The frame rate assumed for a folder of frames when none is given.
FOLDER_FPS = 30.0


@dataclass(frozen=True)
class CorrectionConfig:
    """Everything that decides a correction: timing, method, warp, encoder.

    Build it in Python, from a preset (:meth:`from_preset`), or from flat option names
    (:meth:`with_options`, what the command line does).

    Parameters
    ----------
    method : {'dense', 'paper', 'gyro'}
        Motion estimation: per-pixel flow with a scanline-resolution camera trajectory
        (:mod:`unjello.motion.dense.method`), Liang, Chang & Chen 2008
        (:mod:`unjello.motion.paper.method`),
        or a rotation per scanline from a gyro log (:mod:`unjello.motion.gyro.method`).
    readout : float, str or None
        Readout as a fraction of the frame interval, a time (``"15.7ms"``) or ``"auto"``;
        None: what a sidecar or the file states, else 1.0 (:func:`resolve_timing`).
        Parsed once, here (:func:`unjello.timing.readout_request`).
    direction : str, optional
        Scan direction in coded orientation (default top-bottom).
    reference : {'middle', 'first'}, optional
        Scanline whose time the output shows (default middle).
    fps : float, optional
        Frame rate: a folder's (default 30), or to override a video's.
    warp : {'remap', 'splat'}
        Backward ``cv2.remap`` (fast) or the paper's forward splatting.
    fill : {'nearest', 'black'}
        Content of the area no scanline reaches.
    paper, dense, gyro : PaperConfig, DenseConfig, GyroConfig
        Settings of each method.
    stabilize : StabilizeConfig
        Stabilisation in the same warp (:mod:`unjello.stabilize`; off by default).
    encode : EncodeOptions
        Encoder of an output video.
    threads : int
        Threads for the frames' flows (0: one per core; :mod:`unjello.run.parallel`).
    span : ClipSpan
        The part of the clip to correct (``start``, ``duration``; default all of it).

    Examples
    --------
    >>> CorrectionConfig.from_preset("drone").dense.vibration
    'on'
    >>> CorrectionConfig(readout="36ms").readout
    Milliseconds(value=36.0)
    """

    method: str = "dense"
    readout: ReadoutRequest | None = None
    direction: str | None = None
    reference: str | None = None
    fps: float | None = None
    camera: str | None = None
    lens_profile: str | None = None
    undistort: bool = False
    warp: str = "remap"
    fill: str = "nearest"
    paper: PaperConfig = field(default_factory=PaperConfig)
    dense: DenseConfig = field(default_factory=DenseConfig)
    gyro: GyroConfig = field(default_factory=GyroConfig)
    stabilize: StabilizeConfig = field(default_factory=StabilizeConfig)
    encode: EncodeOptions = field(default_factory=EncodeOptions)
    threads: int = 0
    span: ClipSpan = field(default_factory=ClipSpan)
    #: Where the timing settings came from (``{"readout": "preset my.json"}``).
    origins: Mapping[str, str] = field(default_factory=dict, compare=False, repr=False)

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise SettingsError(f"method must be one of {', '.join(METHODS)}, "
                                f"not {self.method!r}")
        if self.readout is not None:
            object.__setattr__(self, "readout", readout_request(self.readout))
        if self.direction is not None and self.direction not in DIRECTIONS:
            raise SettingsError(f"direction must be one of {', '.join(DIRECTIONS)}, "
                                f"not {self.direction!r}")
        if self.reference is not None and self.reference not in REFERENCES:
            raise SettingsError(f"reference must be one of {', '.join(REFERENCES)}, "
                                f"not {self.reference!r}")
        if self.fps is not None and not (isinstance(self.fps, (int, float))
                                         and 0 < self.fps < 10000):
            raise SettingsError(f"fps must be a positive frame rate, not {self.fps!r}")
        if self.warp not in WARPS:
            raise SettingsError(f"warp must be one of {', '.join(WARPS)}, not {self.warp!r}")
        if self.fill not in FILLS:
            raise SettingsError(f"fill must be one of {', '.join(FILLS)}, not {self.fill!r}")
        if not isinstance(self.threads, int) or self.threads < 0:
            raise SettingsError(f"threads must be 0 (one per core) or more, not "
                                f"{self.threads!r}")
        if self.stabilize.enabled and self.warp == "splat":
            raise SettingsError("stabilize needs warp=remap: the paper's forward splatting "
                                "cannot take the stabilisation in the same warp")

    def with_options(self, origin: str = "settings", **values: Any) -> CorrectionConfig:
        """Return a copy with options set by their flat names (:data:`OPTIONS`).

        Parameters
        ----------
        origin : str
            Where the values come from (``"command line"``, ``"preset drone"``), kept
            for the timing settings in :attr:`origins`.
        **values
            Option names (``readout``, ``flow_preset``, ``camera_only``, ...) and values;
            strings are accepted for numbers (``"0.9"``), as a JSON or flag value would be.

        Raises
        ------
        SettingsError
            An unknown name or a value of the wrong kind.
        """
        unknown = sorted(set(values) - set(OPTIONS))
        if unknown:
            raise SettingsError(f"unknown setting(s) {', '.join(unknown)} (known: "
                                f"{', '.join(OPTIONS)})")
        changes: dict[str, Any] = {}
        for name, value in values.items():
            opt = OPTIONS[name]
            changes[opt.path] = opt.convert(value)
        if values.get("gyro") is not None:  # a log given means the gyro method
            if changes.get("method", self.method) == "paper":
                raise SettingsError("gyro= goes with method=gyro, not method=paper")
            changes["method"] = "gyro"
        origins = dict(self.origins)
        origins.update({n: origin for n in values if n in _TIMING})
        return _replace_paths(self, changes, origins)

    @classmethod
    def from_preset(cls, preset: str | Path, base: CorrectionConfig | None = None
                    ) -> CorrectionConfig:
        """Return the settings of a named preset (:data:`PRESETS`) or of a JSON preset file.

        A JSON preset is one object whose keys are option names (:data:`OPTIONS`, with
        ``-`` or ``_``), for example ``{"readout": "36ms", "method": "paper"}``.

        Parameters
        ----------
        preset : str or path
            A name of :data:`PRESETS`, or a JSON file.
        base : CorrectionConfig, optional
            Settings the preset is applied to (default: the defaults).

        Raises
        ------
        SettingsError
            An unknown name, an unreadable file, or a bad key or value in it.
        """
        base = base or cls()
        name = str(preset)
        if name in PRESETS:
            return base.with_options(origin=f"preset {name}", **PRESETS[name])
        path = Path(preset)
        if not path.is_file():
            raise SettingsError(f"unknown preset {name!r}: use one of {', '.join(PRESETS)} "
                                "or a JSON file")
        try:
            values = json.loads(path.read_text())
        except (OSError, ValueError) as exc:
            raise SettingsError(f"preset {path}: not valid JSON ({exc})") from None
        if not isinstance(values, dict):
            raise SettingsError(f"preset {path}: must be a JSON object of settings")
        values = {str(k).replace("-", "_"): v for k, v in values.items()}
        try:
            return base.with_options(origin=f"preset {path.name}", **values)
        except SettingsError as exc:
            raise SettingsError(f"preset {path}: {exc}") from None

    def option(self, name: str) -> Any:
        """Return the current value of an option, by its flat name (as a flag shows it)."""
        opt = OPTIONS[name]
        value: Any = self
        for part in opt.path.split("."):
            value = getattr(value, part)
        return opt.show(value)


def _replace_paths(obj: Any, changes: dict[str, Any], origins: dict[str, str]) -> Any:
    """``dataclasses.replace`` along dotted paths (``"dense.flow_preset"``)."""
    top: dict[str, Any] = {}
    nested: dict[str, dict[str, Any]] = {}
    for path, value in changes.items():
        head, _, rest = path.partition(".")
        if rest:
            nested.setdefault(head, {})[rest] = value
        else:
            top[head] = value
    for head, sub in nested.items():
        top[head] = _replace_paths(getattr(obj, head), sub, {})
    if isinstance(obj, CorrectionConfig):
        top["origins"] = origins
    try:
        return dataclasses.replace(obj, **top)
    except TypeError as exc:  # a value of the wrong type deep in a method's settings
        raise SettingsError(str(exc)) from None


def _number(name: str, kind: type, value: Any) -> Any:
    """Read a number given as a number or as text; integers must be whole."""
    if value is None:
        return None
    try:
        if isinstance(value, bool):
            raise ValueError
        number = float(value)
        if kind is int:
            if not number.is_integer():
                raise ValueError
            return int(number)
        return number
    except (TypeError, ValueError, OverflowError):
        raise SettingsError(f"{name}={value!r} is not "
                            f"{'an integer' if kind is int else 'a number'}") from None


def _flag(name: str, value: Any) -> bool:
    """Read a switch given as a bool or as text (true/false, yes/no, on/off, 1/0)."""
    if isinstance(value, bool):
        return value
    text = str(value).strip().lower()
    if text in ("true", "1", "yes", "on"):
        return True
    if text in ("false", "0", "no", "off"):
        return False
    raise SettingsError(f"{name}={value!r} is not true or false")


@dataclass(frozen=True)
class Option:
    """One knob: its flat name (preset key, ``--flag``), where it lives, how it reads.

    Attributes
    ----------
    name : str
        Preset key; the flag is ``--`` + the name with ``-`` for ``_``.
    path : str
        Attribute path in :class:`CorrectionConfig` (``"dense.flow_preset"``).
    help : str
        One sentence for ``--help``.
    kind : {'str', 'int', 'float', 'flag', 'path'}
        How a flag's text is read.
    choices : tuple of str
        The allowed values, if a few.
    to_field, from_field : callable, optional
        Conversions between the option's value and the field's (a flag that negates a
        field, milliseconds stored as seconds).
    per_clip : bool
        Belongs to one clip (a gyro log): ``correct`` has it, ``batch`` not.
    """

    name: str
    path: str
    help: str
    kind: str = "str"
    choices: tuple[str, ...] = ()
    to_field: Callable[[Any], Any] | None = None
    from_field: Callable[[Any], Any] | None = None
    per_clip: bool = False

    @property
    def flag(self) -> str:
        """The command-line flag, e.g. ``--flow-preset``."""
        return "--" + self.name.replace("_", "-")

    def convert(self, value: Any) -> Any:
        """Read a value as given (Python, JSON or flag text) into the field's value."""
        if self.kind == "flag":
            value = _flag(self.name, value)
        elif self.kind in ("int", "float"):
            value = _number(self.name, int if self.kind == "int" else float, value)
        elif value is not None and self.kind == "path":
            value = str(value)
        return self.to_field(value) if self.to_field is not None else value

    def show(self, value: Any) -> Any:
        """Return the option's value for a field's value."""
        return self.from_field(value) if self.from_field is not None else value


def _vibration(value: Any) -> Any:
    return {True: "on", False: "off"}.get(value, value) if isinstance(value, bool) else value


def _coefficients(value: Any) -> Any:
    """``"k1,k2,k3,k4"`` (or a list of four numbers) -> a tuple of floats."""
    if value is None or isinstance(value, tuple):
        return value
    parts = value.split(",") if isinstance(value, str) else list(value)
    try:
        return tuple(float(v) for v in parts)
    except (TypeError, ValueError):
        raise SettingsError(f"distortion must be four numbers k1,k2,k3,k4, got {value!r}"
                            ) from None


def _show_coefficients(value: Any) -> Any:
    return None if value is None else ",".join(f"{v:g}" for v in value)


def _show_time(value: Any) -> Any:
    return None if value is None else str(value)


def _ms_to_s(value: Any) -> Any:
    return None if value is None else value / 1e3


def _s_to_ms(value: Any) -> Any:
    return None if value is None else value * 1e3


#: Every knob, in the order ``--help`` lists them.
OPTIONS: dict[str, Option] = {o.name: o for o in (
    Option("method", "method", "Motion model: 'dense' = per-pixel flow with a "
           "scanline-resolution camera trajectory; 'paper' = Liang, Chang & Chen 2008; "
           "'gyro' = a rotation per scanline from a gyro log.", choices=METHODS),
    Option("readout", "readout", "Readout time: fraction of the frame interval (0 < r <= 1), "
           "milliseconds (15.7ms), or 'auto' (stated by the file, else estimated from the "
           "motion). Default: what a sidecar or the file's metadata states, else 1.0."),
    Option("direction", "direction", "Order the sensor reads its lines (coded orientation; "
           "default top-bottom).", choices=DIRECTIONS),
    Option("reference", "reference", "Scanline whose time the output shows (default "
           "middle).", choices=REFERENCES),
    Option("fps", "fps", "Frame rate of a folder of frames (default 30), for readouts in ms "
           "and the gyro method; overrides a video's.", kind="float"),
    Option("camera", "camera", "Camera, as `unjello cameras` lists it (e.g. 'GoPro HERO5 "
           "Black'): its readout and scan direction from the camera database, for the "
           "clip's size and frame rate. Default: the camera the file names."),
    Option("lens_profile", "lens_profile", "A Gyroflow lens profile (JSON): its "
           "frame_readout_time, and its lens for the gyro method and for undistorting.",
           kind="path", per_clip=True),
    Option("undistort", "undistort", "Remove the fisheye lens's curvature from the output "
           "(a pinhole picture of the same focal length and size); needs the lens: a lens "
           "profile, a camera the database has one for, or the focal length and "
           "distortion.", kind="flag"),
    Option("warp", "warp", "Backward remap (fast) or the paper's forward splat.",
           choices=WARPS),
    Option("fill", "fill", "What fills the area no scanline reaches.", choices=FILLS),
    Option("search", "paper.global_motion.search", "Paper method: global block-matching "
           "search range, px.", kind="int"),
    Option("flow_preset", "dense.flow_preset", "Dense method: DIS optical flow preset "
           "(speed vs accuracy).", choices=("ultrafast", "fast", "medium")),
    Option("flow_detail", "dense.detail", "Dense method: 'full' measures the flow at the "
           "working copy's full resolution; 'polished' at half of it, refined at full (half "
           "the flow's cost, 0.1 dB less on the research pairs; misses fast spinners); "
           "'checked' polished where it explains the frame pair, full where not (spinners, "
           "jello).", choices=DETAILS),
    Option("work_width", "dense.work_width", "Dense method: estimate motion on frames at "
           "most this wide (0: full).", kind="int"),
    Option("camera_only", "dense.per_pixel", "Dense method: camera trajectory only, one "
           "displacement per scanline (fast; no per-pixel parallax or moving objects).",
           kind="flag", to_field=lambda v: not v, from_field=lambda v: not v),
    Option("edge_refine", "dense.edge_refine", "Dense method: near motion boundaries give "
           "each pixel the flow of the side it matches (less motion error at object edges, "
           "up to a third slower).", kind="flag"),
    Option("vibration", "dense.vibration", "Dense method: follow vibration near the frame "
           "rate (drone jello) with a 1 s window; 'auto' turns it on when the first frames "
           "wobble.", choices=("auto", "on", "off"), to_field=_vibration),
    Option("gyro", "gyro.path", "Gyro log of the clip (text or CSV: a time and three "
           "angular rates per line); implies --method gyro. Default with --method gyro: "
           "NAME.gyro.csv beside the clip.", kind="path", per_clip=True),
    Option("gyro_layout", "gyro.layout", "Column order of the gyro log, e.g. t,x,y,z; auto: "
           "the increasing column is the time.", per_clip=True),
    Option("gyro_units", "gyro.units", "Unit of the logged rates (per second).",
           choices=("rad", "deg"), per_clip=True),
    Option("gyro_axes", "gyro.axes", "Camera x, y, z as gyro axes, e.g. XYZ or yXz (lower "
           "case: negated); auto: found from the footage's motion.", per_clip=True),
    Option("gyro_offset", "gyro.offset", "Time on the log's clock of the first frame, ms; "
           "default: found from the footage's motion.", kind="float", to_field=_ms_to_s,
           from_field=_s_to_ms, per_clip=True),
    Option("focal", "gyro.focal", "Focal length in pixels of the frame (gyro method); "
           "default: the lens profile's or the camera database's, else found from the "
           "footage's motion.", kind="float", per_clip=True),
    Option("distortion", "gyro.distortion", "Fisheye lens distortion k1,k2,k3,k4 (OpenCV's "
           "model, as in Gyroflow's lens profiles) for the gyro method; default: the lens "
           "profile's or the camera database's, else none (a pinhole).", per_clip=True,
           to_field=_coefficients, from_field=_show_coefficients),
    Option("start", "span.start", "Correct from this time of the clip on: seconds (12.5, "
           "1:02.5) or frames (150f); the motion is still measured from the frames around.",
           to_field=clip_time, from_field=_show_time, per_clip=True),
    Option("duration", "span.duration", "Correct this long a part of the clip (seconds or "
           "frames, as --start); the output's time starts at zero and its audio is cut to "
           "match.", to_field=clip_time, from_field=_show_time, per_clip=True),
    Option("stabilize", "stabilize.enabled", "Also stabilise: render every frame at a "
           "smoothed camera path, in the same warp as the correction.", kind="flag"),
    Option("smoothness", "stabilize.smoothness", "Stabilisation: how smooth the camera path "
           "is, seconds: shake faster than about 0.2 / smoothness Hz goes (default 0.3).",
           kind="float"),
    Option("crop", "stabilize.crop", "Stabilisation: 'auto' (the least zoom that keeps the "
           "borders filled, changing gradually), 'none', or a fraction cut from each "
           "side pair, e.g. 0.1.", to_field=crop_request),
    Option("threads", "threads", "Threads measuring the frames' motion ahead (0: one per "
           "core).", kind="int"),
    Option("codec", "encode.codec", "Encoder of the output video (libx264; writing to "
           "standard output, rawvideo)."),
    Option("format", "encode.format", "Container of the output when it is standard output "
           "(-o -): nut (pts and audio kept; default), yuv4mpegpipe (raw frames), matroska "
           "or mpegts.", choices=("nut", "yuv4mpegpipe", "matroska", "mpegts")),
    Option("crf", "encode.crf", "Encoder quality (0-51, lower is better).", kind="int"),
    Option("x264_preset", "encode.preset", "libx264/libx265 speed/size preset (ultrafast ... "
           "veryslow)."),
    Option("profile", "encode.profile", "ProRes (prores_ks: proxy, lt, standard, hq, 4444, "
           "4444xq; default hq) or DNxHR (dnxhd: dnxhr_lb, dnxhr_sq, dnxhr_hq, dnxhr_hqx, "
           "dnxhr_444; default dnxhr_hq) profile."),
)}

_TIMING = ("readout", "direction", "reference", "fps", "camera", "lens_profile")

#: Named presets: option names and values, applied under the command line's.
PRESETS: dict[str, dict[str, Any]] = {
    # The paper's own output: its method, forward splatting, black where nothing lands.
    "paper-figures": {"method": "paper", "warp": "splat", "fill": "black"},
    # Transcode-rate speed: the camera trajectory alone (no per-pixel parallax), from
    # DIS "ultrafast" flow on a 320 px copy; the encoder settings stay as given.
    "fast": {"camera_only": True, "flow_preset": "ultrafast", "work_width": 320},
    # The finest flow on every frame pair (the default until issue 37: a little more quality
    # on parallax and moving objects, the flow at twice the cost).
    "best": {"flow_detail": "full"},
    # Drones and vehicles: vibration near the frame rate.
    "drone": {"vibration": "on"},
    # Hand-held walking shots: the correction and a stabilisation in one warp.
    "handheld": {"stabilize": True},
}
