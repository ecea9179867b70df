"""The Trajectory: per-frame, per-scanline motion, the hub between all stages.

For frame ``n`` a :class:`FrameMotion` holds, for every scanline ``r`` (in top-bottom
orientation, see :mod:`unjello.timing`):

* ``velocity[r]`` -- the estimated image velocity ``v'(t_r)`` in px per frame interval;
* ``displacement[r]`` -- ``Delta(r) = integral from t_ref to t_r of v'(t) dt``, the shift
  of that scanline relative to where it belongs at the reference time (paper eq. 26:
  the corrected position of pixel ``s`` is ``p = s - Delta(s_y)``).

Methods produce it; the warper, the exports, the metrics and the plots consume it.

The JSON form (``schema: "unjello.trajectory"``, ``version: 1``) stores the method, the
timing (``readout``, ``direction``, ``reference``), the frame size (``width``,
``height``, coded orientation), the clip's ``fps`` and ``source`` (when known) and, per
frame: ``index``, ``start`` (time of the first
scanline in frame intervals), ``ok``, ``note``, ``events`` (what the method did to the
frame, as codes of :data:`EVENTS`; left out when none), ``fallback`` (dense methods: share of
pixels on the camera motion), ``entering`` (of those, content entering the frame),
``kept`` (share given the motion around it because the per-pixel motion folded or tore
the picture), ``spun`` (the share given a rigid motion fitted to an object the flow
failed on: a rotation, or a velocity of its own), ``folds`` (share where the applied
map still folds or tears in blobs), ``unseen`` (share of the output showing what no
frame saw: beyond the frame's edge), ``confidence`` (:attr:`FrameMotion.confidence`,
written for readers; recomputed on load),
``displacement`` and ``velocity`` (``[x, y]`` per scanline, top-bottom orientation),
``camera`` (dense per-pixel: the camera trajectory's own per-scanline displacement),
and for dense methods ``field`` (the per-pixel displacement every 8 pixels, ``[row][col]
[x, y]``) with its full ``field_shape`` ``[h, w]``; when stabilised, ``shift`` ``[x, y]``
and ``zoom`` (the :class:`Reframe` the warp applied on top of the correction), ``angle``
(radians) and ``path`` (the measured camera path: x, y, roll); where a rotation was fitted
to a spinning object, ``front``: one entry per object, each ``{"shape": [h, w], "layer":
[row][col][dx, dy, weight]}`` every 8 pixels (:attr:`FrameMotion.front`).

Version 2 stores each of those arrays packed (a few hundred kB a second of 480p video,
against 9 MB of version 1's lists of decimals): ``{"shape": [...], "scale": s, "zlib":
base64}``, the base64 of the zlib-compressed little-endian int32 steps between
consecutive rows of ``round(array / scale)``. In NumPy::

    q = np.frombuffer(zlib.decompress(base64.b64decode(p["zlib"])), "<i4")
    array = np.cumsum(q.reshape(p["shape"]), axis=0) * p["scale"]

The scales are 1e-4 px for ``displacement`` and ``velocity``, 1e-2 px for ``field`` and
1e-3 for ``front`` (what :meth:`FrameMotion.to_dict` keeps). Version 1 (lists) is still
read. A name ending ``.gz`` (``motion.json.gz``) is gzip-compressed as a whole.
"""

from __future__ import annotations

import base64
import gzip
import io
import json
import os
import zlib
from dataclasses import dataclass, field, fields
from pathlib import Path

import cv2
import numpy as np

from .errors import InputError, cannot_write
from .timing import SensorTiming

__all__ = ["Diagnostics", "FrameMotion", "Reframe", "Stretch", "Trajectory", "TrajectoryWriter",
           "SCHEMA_VERSION", "EVENTS", "pack", "unpack"]

SCHEMA_VERSION = 2
FIELD_STEP = 8


@dataclass(frozen=True)
class Reframe:
    """How a corrected frame is shown (stabilisation, :mod:`unjello.stabilize`).

    Output pixel ``p`` shows the corrected frame at ``c + R(-angle) (p - c) / zoom - shift``,
    ``c`` the frame's centre, ``R`` a rotation in pixel coordinates (x right, y down:
    a positive angle turns x towards y); ``shift`` is in pixels of the full frame, and
    everything in top-bottom orientation. The identity is the plain correction.
    """

    shift: tuple[float, float] = (0.0, 0.0)
    zoom: float = 1.0
    angle: float = 0.0
    #: The camera path the stabiliser measured at this frame: x, y (px) and roll
    #: (radians) from the clip's first frame; with ``shift`` and ``angle``, the smoothed one.
    path: tuple[float, float, float] = (0.0, 0.0, 0.0)

    @property
    def identity(self) -> bool:
        """True when the frame is shown as corrected."""
        return self.shift == (0.0, 0.0) and self.zoom == 1.0 and self.angle == 0.0


#: What a method may do to a frame beyond measuring it (:attr:`FrameMotion.events`).
EVENTS: dict[str, str] = {
    "bridged": "no global motion was found near the frame: its velocity is bridged",
    "diverged": "the paper's local samples diverged: the global motion alone is used",
    "still": "a neighbouring frame shows no motion at all: the frame is left as is",
    "unexplained": "the paper's Bezier velocity does not explain the frame's motion (a "
                   "vibration?): the frame is left as is",
    "no-motion": "no reliable motion: the frame is left as is",
    "kept-folds": "regions given the motion around them: their per-pixel motion folded or "
                  "tore the picture",
    "kept-before": "regions given the motion around them: their object's motion failed in "
                   "the frame before too",
    "spinning": "an object turned back by a rotation fitted per scanline",
    "drifting": "an object carried by a velocity of its own, fitted per scanline",
    "folds": "the correction still folds or tears a visible share of the picture",
}


@dataclass(frozen=True)
class Diagnostics:
    """What a frame's motion rests on, as shares of its pixels (0-1; 0 where not measured).

    Attributes
    ----------
    fallback : float
        Dense methods: pixels whose flow was unreliable and which follow the camera
        (per-scanline) motion instead.
    entering : float
        Dense methods: the part of ``fallback`` that is content entering the frame (no
        neighbour saw it), as opposed to flow that failed its check.
    kept : float
        Dense methods: pixels given the motion of their surroundings because their own
        folded or tore the picture (:func:`unjello.motion.objects.folds.keep_whole`).
    folds : float
        Dense methods: pixels in blobs where the applied map still folds or tears the
        picture (:func:`unjello.motion.objects.folds.fold_share`): motion not followed.
    spun : float
        Dense methods: pixels given a rigid motion fitted to an object the flow failed on
        (:func:`unjello.motion.objects.spinners.keep_spinning`): a rotation (a spinning
        object) or a velocity of its own (a near object passing).
    unseen : float
        The output picture's share whose source lies beyond the frame's edge and that no
        neighbouring frame supplied: set by the warper
        (:attr:`unjello.warp.warper.PictureWarper.unseen`), 0 before warping.
    """

    fallback: float = 0.0
    entering: float = 0.0
    kept: float = 0.0
    folds: float = 0.0
    spun: float = 0.0
    unseen: float = 0.0

    def confidence(self, ok: bool = True) -> float:
        """Share of the picture corrected by motion measured for it, 0-1.

        One minus the pixels whose own motion was not measured -- their flow failed
        (``fallback`` less ``entering``: content entering the frame is no failure, it
        moves with the camera) or they were given the motion around them (``kept``; the
        two mostly overlap, the larger counts) -- less those a rigid motion fitted to an
        object explains (``spun``), and minus those where the correction still folds or
        tears (``folds``). A frame bridged over a failure (``ok`` false) has 0.
        """
        if not ok:
            return 0.0
        unmeasured = max(self.fallback - self.entering, self.kept) - self.spun
        doubt = max(unmeasured, 0.0) + self.folds
        return float(np.clip(1.0 - doubt, 0.0, 1.0))

    def to_dict(self) -> dict:
        """Return the shares rounded to 1e-4, by name."""
        return {f.name: round(float(getattr(self, f.name)), 4) for f in fields(self)}

    @classmethod
    def from_dict(cls, d: dict) -> Diagnostics:
        """Read the shares :meth:`to_dict` wrote (absent ones 0)."""
        return cls(**{f.name: float(d.get(f.name, 0.0)) for f in fields(cls)})


@dataclass(frozen=True)
class FrameMotion:
    """Motion of one frame's scanlines.

    Parameters
    ----------
    index : int
        Frame number in the clip.
    start : float
        Time of the frame's first scanline, in frame intervals.
    displacement : ndarray of shape (h, 2)
        Per-scanline ``(dx, dy)`` from the reference time to the scanline's time (eq. 26).
    velocity : ndarray of shape (h, 2)
        Per-scanline velocity in px per frame interval.
    ok : bool
        False when the estimate was bridged over a failure (see ``note``).
    note : str
        Why the estimate is not a direct measurement, if so.
    diagnostics : Diagnostics
        What the motion rests on, as shares of the picture (dense methods, the warper).
    field : ndarray of shape (hf, wf, 2), optional
        Per-pixel displacement for dense methods (``p = s - field[s]``), in pixels of
        the full frame but possibly sampled at a lower resolution (dense motion is
        smooth; consumers interpolate it); when present it is what the warper applies,
        and ``displacement`` is its per-row median.
    front : tuple of ndarray, optional
        Dense methods: one layer per spinning object turned back by a fitted rotation,
        shown in front of ``field``, each of shape (hf, wf, 3) on the field's grid: the
        rotation's backward displacement ``(dx, dy)`` (the output pixel ``p`` shows the
        frame's ``p + (dx, dy)``, in pixels of the full frame) and the object's weight
        (0-1) at each pixel of the frame. Where the rotated object lands, the picture
        takes the rotation's source (:func:`unjello.warp.maps.front_maps`): a forward
        ``field`` alone cannot show a turned-back tip over the background it lands on.
    neighbours : tuple of (int, ndarray), optional
        Dense methods: the flow from this frame to the frame ``offset`` away, shape
        (hf, wf, 2) in pixels of its own (hf, wf) grid, for filling what this frame does
        not see from its neighbours (not saved; dropped with ``field``).
    reframe : Reframe
        The stabilisation's shift and zoom, applied in the same warp (identity without).
    camera : ndarray of shape (h, 2), optional
        Dense per-pixel method: the camera trajectory's own per-scanline displacement
        (what ``camera_only`` would apply; ``displacement`` is then the field's per-row
        median, objects included). None where ``displacement`` is the camera's already.
    events : tuple of str
        What the method did to this frame beyond measuring it, as codes of
        :data:`EVENTS` (one per object for ``spinning`` and ``drifting``); ``note`` says
        the same in words.
    """

    index: int
    start: float
    displacement: np.ndarray
    velocity: np.ndarray
    ok: bool = True
    note: str = ""
    diagnostics: Diagnostics = Diagnostics()
    field: np.ndarray | None = None
    front: tuple[np.ndarray, ...] = ()
    neighbours: tuple[tuple[int, np.ndarray], ...] = ()
    reframe: Reframe = Reframe()
    camera: np.ndarray | None = None
    events: tuple[str, ...] = ()

    @property
    def camera_displacement(self) -> np.ndarray:
        """The camera's per-scanline displacement, shape (h, 2) (module notes)."""
        return self.displacement if self.camera is None else self.camera

    @property
    def confidence(self) -> float:
        """Share of the picture corrected by measured motion (:meth:`Diagnostics.confidence`)."""
        return self.diagnostics.confidence(self.ok)

    def pixel_displacement(self, width: int) -> np.ndarray:
        """Return the per-pixel displacement at full resolution, shape ``(h, width, 2)``."""
        h = self.displacement.shape[0]
        if self.field is not None:
            if self.field.shape[:2] == (h, width):
                return self.field
            return cv2.resize(self.field, (width, h), interpolation=cv2.INTER_LINEAR)
        return np.broadcast_to(self.displacement[:, None, :],
                               (self.displacement.shape[0], width, 2))

    def to_dict(self) -> dict:
        """Return a JSON-serialisable dict of this frame.

        A per-pixel field is stored every ``FIELD_STEP`` pixels of the frame (``field``,
        with its own ``field_shape``; a field sampled more coarsely already, such as the
        gyro method's, is stored as it is); reading it back interpolates it bilinearly.
        """
        d = {
            "index": int(self.index),
            "start": float(self.start),
            "ok": bool(self.ok),
            "note": self.note,
            **self.diagnostics.to_dict(),
            "confidence": round(self.confidence, 4),
            "displacement": pack(self.displacement, 1e-4),
            "velocity": pack(self.velocity, 1e-4),
        }
        if self.events:
            d["events"] = list(self.events)
        if self.camera is not None:
            d["camera"] = pack(self.camera, 1e-4)
        if not self.reframe.identity:
            d["shift"] = [round(float(v), 4) for v in self.reframe.shift]
            d["zoom"] = round(float(self.reframe.zoom), 6)
            d["angle"] = round(float(self.reframe.angle), 7)
            d["path"] = [round(float(v), 7) for v in self.reframe.path]
        if self.field is not None:
            h, w = self.field.shape[:2]
            # The field's grid may be coarser than the frame (the dense method's working
            # copy): FIELD_STEP frame pixels are this many of its samples.
            step = FIELD_STEP * h / self.displacement.shape[0]
            small = _every(self.field, step)
            d["field_shape"] = [h, w]
            d["field"] = pack(small, 1e-2)
            if self.front:
                d["front"] = [{"shape": [h, w], "layer": pack(_every(layer, step), 1e-3)}
                              for layer in self.front]
        return d

    @classmethod
    def from_dict(cls, d: dict) -> FrameMotion:
        """Build a frame from :meth:`to_dict`'s output."""
        def grid(values: list | dict, shape: list) -> np.ndarray:
            h, w = (int(v) for v in shape)
            return cv2.resize(unpack(values).astype(np.float32), (w, h),
                              interpolation=cv2.INTER_LINEAR)

        field = grid(d["field"], d["field_shape"]) if d.get("field") is not None else None
        front = tuple(grid(f["layer"], f["shape"]) for f in d.get("front", ()))
        return cls(
            index=int(d["index"]),
            start=float(d["start"]),
            displacement=unpack(d["displacement"]).reshape(-1, 2),
            velocity=unpack(d["velocity"]).reshape(-1, 2),
            ok=bool(d.get("ok", True)),
            note=str(d.get("note", "")),
            events=tuple(str(e) for e in d.get("events", ())),
            diagnostics=Diagnostics.from_dict(d),
            field=field,
            front=front,
            camera=unpack(d["camera"]).reshape(-1, 2) if d.get("camera") is not None else None,
            reframe=Reframe(tuple(float(v) for v in d.get("shift", (0.0, 0.0))),  # type: ignore[arg-type]
                            float(d.get("zoom", 1.0)), float(d.get("angle", 0.0)),
                            tuple(float(v) for v in d.get("path", (0.0, 0.0, 0.0)))),  # type: ignore[arg-type]
        )


def pack(values: np.ndarray, scale: float) -> dict:
    """Pack an array for the JSON document (version 2; the module notes give the layout).

    Rounded to multiples of ``scale``; the steps between consecutive rows, which are small
    for smooth motion, compress well.

    Examples
    --------
    >>> a = np.array([[1.25, -3.5], [1.5, -3.25]])
    >>> bool(np.array_equal(unpack(pack(a, 1e-2)), a))
    True
    """
    q = np.round(np.asarray(values, np.float64) / scale).astype("<i4")
    steps = np.diff(q, axis=0, prepend=np.zeros_like(q[:1])) if q.ndim else q
    return {"shape": list(q.shape), "scale": scale,
            "zlib": base64.b64encode(zlib.compress(steps.tobytes(), 9)).decode("ascii")}


def unpack(stored: list | dict) -> np.ndarray:
    """Read an array stored by :func:`pack`, or a version-1 list of numbers, as float64."""
    if not isinstance(stored, dict):
        return np.asarray(stored, dtype=np.float64)
    try:
        steps = np.frombuffer(zlib.decompress(base64.b64decode(stored["zlib"])), "<i4")
        q = steps.reshape([int(v) for v in stored["shape"]])
    except (KeyError, ValueError, TypeError, zlib.error) as exc:
        raise InputError(f"a damaged array in the motion file ({exc})") from None
    return (np.cumsum(q, axis=0, dtype=np.int64) if q.ndim else q) * float(stored["scale"])


def _every(values: np.ndarray, step: float) -> np.ndarray:
    """``values`` (h, w, c) averaged down to one sample every ``step`` of them."""
    h, w = values.shape[:2]
    if step <= 1:
        return np.asarray(values, np.float32)
    return cv2.resize(values.astype(np.float32),
                      (max(1, round(w / step)), max(1, round(h / step))),
                      interpolation=cv2.INTER_AREA)


@dataclass(frozen=True)
class Stretch:
    """A stretch of a clip between breaks (cuts, flashes, size changes), and its model.

    Attributes
    ----------
    first, last : int
        Its first and last frame (``last`` is -1 while it goes on).
    why : str
        What started it: ``'start'`` (the clip's), ``'cut'``, or streams joined: ``'size'``
        (another picture size) or ``'time'`` (timestamps that started over)
        (:mod:`unjello.motion.cuts`).
    evidence : dict
        The break's measurements (``similarity``, ``light``, ``tones``).
    model : str or None
        The dense method's camera model at its start: ``'smooth'`` or ``'vibration'``.
    choice : dict
        The evidence that chose it (:attr:`unjello.motion.dense.method.DenseMethod.choice`).
    models : tuple of (int, str, dict)
        Every choice over it: from which frame, the model, the evidence (the model is
        chosen again as the footage goes: a drone that lands, a car that stops).
    wobble : float or None
        The vibration's wobble (share of the height) where the vibration model was chosen.
    """

    first: int
    why: str
    evidence: dict = field(default_factory=dict)
    last: int = -1
    model: str | None = None
    choice: dict = field(default_factory=dict)
    wobble: float | None = None
    models: tuple = ()

    def ended(self, last: int, method: object) -> Stretch:
        """Return it ended at frame ``last``, with the models ``method`` took over it."""
        models = tuple((self.first + k, name, dict(choice))
                       for k, name, choice in getattr(method, "decisions", ()))
        vibrating = getattr(method, "vibrating", None)
        model = models[0][1] if models else (
            None if vibrating is None else "vibration" if vibrating else "smooth")
        return Stretch(self.first, self.why, self.evidence, last, model,
                       dict(getattr(method, "choice", {}) or {}),
                       getattr(method, "wobble", None), models)

    def as_json(self) -> dict:
        """Return it as ``correct --json`` gives it."""
        return {"first": self.first, "last": self.last, "why": self.why,
                "evidence": self.evidence, "model": self.model, "choice": self.choice,
                "models": [{"from": k, "model": name, "choice": choice}
                           for k, name, choice in self.models]}


@dataclass
class Trajectory:
    """Per-scanline motion of a whole clip.

    Parameters
    ----------
    timing : SensorTiming
        Readout, direction and reference the displacements refer to.
    size : tuple of int
        ``(width, height)`` of the frames in coded orientation.
    frames : list of FrameMotion
        One entry per frame, in order.
    method : str
        Name of the method that produced it (``'paper'``, ``'truth'``, ...).
    vibration : float, optional
        The dense method's detected vibration (its wobble, a share of the height) when
        ``vibration='auto'`` switched its window on; None otherwise (not stored in JSON).
    stretches : list of Stretch
        The clip's stretches between breaks, as the run found them (not stored in JSON).
    fps : float, optional
        Frames per second of the clip (the unit of ``start`` is its frame interval).
    source : str
        The clip the motion was measured on, as it was given ('' if unknown).
    """

    timing: SensorTiming
    size: tuple[int, int]
    frames: list[FrameMotion] = field(default_factory=list)
    method: str = ""
    vibration: float | None = None
    fps: float | None = None
    source: str = ""
    stretches: list[Stretch] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.frames)

    def displacements(self) -> np.ndarray:
        """Return all displacements stacked, shape ``(n_frames, h, 2)``."""
        return np.stack([f.displacement for f in self.frames])

    def to_json(self) -> dict:
        """Return the versioned JSON document (see the module docstring)."""
        return {
            "schema": "unjello.trajectory",
            "version": SCHEMA_VERSION,
            "method": self.method,
            "readout": self.timing.readout,
            "direction": self.timing.direction,
            "reference": self.timing.reference,
            "width": int(self.size[0]),
            "height": int(self.size[1]),
            **({"fps": float(self.fps)} if self.fps else {}),
            **({"source": self.source} if self.source else {}),
            "frames": [f.to_dict() for f in self.frames],
        }

    @classmethod
    def from_json(cls, doc: dict) -> Trajectory:
        """Read a document written by :meth:`to_json`."""
        if doc.get("schema") != "unjello.trajectory":
            raise InputError("not an unjello trajectory file (schema field missing)")
        if int(doc.get("version", 0)) > SCHEMA_VERSION:
            raise InputError(f"trajectory version {doc['version']} is newer than supported")
        timing = SensorTiming(doc["readout"], doc["direction"], doc["reference"])
        return cls(
            timing=timing,
            size=(int(doc["width"]), int(doc["height"])),
            frames=[FrameMotion.from_dict(f) for f in doc["frames"]],
            method=str(doc.get("method", "")),
            fps=float(doc["fps"]) if doc.get("fps") else None,
            source=str(doc.get("source", "")),
        )

    def save(self, path: str | os.PathLike) -> None:
        """Write the JSON document atomically to ``path`` (gzip-compressed for ``.gz``)."""
        path = Path(path)
        tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
        with _open_text(tmp, "w") as f:
            f.write(json.dumps(self.to_json()))
        os.replace(tmp, path)

    @classmethod
    def load(cls, path: str | os.PathLike) -> Trajectory:
        """Read a trajectory JSON file (``.gz``: gzip-compressed)."""
        try:
            with _open_text(Path(path), "r") as f:
                doc = json.loads(f.read())
        except (OSError, ValueError, EOFError) as exc:
            raise InputError(f"cannot read trajectory {path}: {exc}") from None
        if not isinstance(doc, dict):
            raise InputError(f"{path}: not an unjello trajectory file")
        return cls.from_json(doc)


def _open_text(path: Path, mode: str) -> io.TextIOBase:
    """Open a text file, through gzip where its name ends ``.gz``."""
    if path.name.lower().endswith(".gz"):
        return gzip.open(path, mode + "t", encoding="utf-8")  # type: ignore[return-value]
    return path.open(mode, encoding="utf-8")  # type: ignore[return-value]


class TrajectoryWriter:
    """Write a trajectory JSON frame by frame (constant memory), atomically.

    Produces the same document as :meth:`Trajectory.save`.

    Parameters
    ----------
    path : path-like
        Destination; written under a temporary name until :meth:`close`.
    header : Trajectory
        Supplies the method, timing and size (its frames are ignored), read when the
        first frame is written.
    """

    def __init__(self, path: str | os.PathLike, header: Trajectory) -> None:
        self.path = Path(path)
        self._tmp = self.path.with_name(f".{self.path.name}.tmp{os.getpid()}"
                                        + (".gz" if self.path.name.lower().endswith(".gz")
                                           else ""))
        self._header = header
        try:
            self._f = _open_text(self._tmp, "w")
        except OSError as exc:
            raise cannot_write(self.path, exc) from None
        self._n = 0

    def _open(self) -> None:
        """Write the header as it stands at the first frame.

        A method that falls back to another says so before its first frame.
        """
        doc = self._header.to_json()
        doc["frames"] = []
        self._f.write(json.dumps(doc)[:-2])  # up to "frames": [

    def write(self, frame: FrameMotion) -> None:
        """Append one frame."""
        if not self._n:
            self._open()
        self._f.write(("," if self._n else "") + json.dumps(frame.to_dict()))
        self._n += 1

    def close(self) -> None:
        """Finish the document and move it into place."""
        if not self._n:
            self._open()
        self._f.write("]}")
        self._f.close()
        os.replace(self._tmp, self.path)

    def abort(self) -> None:
        """Drop the partial file."""
        self._f.close()
        self._tmp.unlink(missing_ok=True)
