"""Preview: one frame corrected with settings that change, to tune the readout by eye.

:class:`PreviewClip` holds a clip's frames (losslessly, in a temporary folder, a few
decoded in memory) and corrects one frame at a time with :class:`PreviewSettings`: the
method runs over the few frames around it that its motion depends on, and only that
frame is warped. The dense method's flows between frame pairs do not depend on the
readout or the reference, so they are measured once and kept
(:class:`~unjello.motion.dense.method.DenseMethod`'s ``flows``): changing the readout, the
reference or the method's model re-solves the camera and warps one frame, well under a
second at 1080p (``benchmarks/preview.py``). The result is the frame ``unjello correct``
gives with the same settings (:meth:`PreviewSettings.command` writes that command).

The web page and its JSON/PNG API are :mod:`unjello.webapp`; this module knows nothing
of HTTP.
"""

from __future__ import annotations

import dataclasses
import json
import os
import shlex
import tempfile
import threading
import time
from collections import OrderedDict
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import cv2
import numpy as np

from ..clip import resolve_clip
from ..config import CorrectionConfig
from ..errors import InputError, SettingsError
from ..io.frames import read_image, write_image
from ..io.source import FrameSource, read_frames
from ..pipeline import Corrector
from ..readout.footage import estimate_readout
from ..timing import DIRECTIONS, REFERENCES, Direction, Reference, SensorTiming
from ..trajectory import FrameMotion, Trajectory

__all__ = ["PreviewSettings", "PreviewClip", "PREVIEW_METHODS", "encode_png"]

#: Methods the preview shows (the gyro method calibrates on the whole clip).
PREVIEW_METHODS = ("dense", "paper")

# Frames each side of the shown one that its motion depends on (the dense method's
# window is two pairs each side, the paper's Bezier curve n - 1 ... n + 2).
_AROUND = 3
# Frames the footage's readout estimate is made from (at start-up).
_ESTIMATE_FRAMES = 30


class _LRU(OrderedDict):
    """A mapping that forgets its least recently used entries beyond ``size``."""

    def __init__(self, size: int) -> None:
        super().__init__()
        self.size = size

    def __getitem__(self, key: Any) -> Any:
        value = super().__getitem__(key)
        self.move_to_end(key)
        return value

    def get(self, key: Any, default: Any = None) -> Any:
        return self[key] if key in self else default

    def __setitem__(self, key: Any, value: Any) -> None:
        super().__setitem__(key, value)
        self.move_to_end(key)
        while len(self) > self.size:
            self.popitem(last=False)


@dataclass(frozen=True)
class PreviewSettings:
    """The settings the page turns: method, readout, direction, reference, model.

    Parameters
    ----------
    method : {'dense', 'paper'}
    readout : float
        Fraction of the frame interval, 0 < readout <= 1, to four decimals (as the command
        line gives it).
    direction, reference : str
        As :class:`~unjello.timing.SensorTiming`.
    camera_only : bool
        Dense method: one displacement per scanline.
    """

    method: str = "dense"
    readout: float = 1.0
    direction: str = "top-bottom"
    reference: str = "middle"
    camera_only: bool = False

    def __post_init__(self) -> None:
        if self.method not in PREVIEW_METHODS:
            raise SettingsError(f"the preview shows the methods {', '.join(PREVIEW_METHODS)}"
                                f", not {self.method!r} (use unjello correct)")
        if not (isinstance(self.readout, (int, float)) and 0 < self.readout <= 1):
            raise SettingsError(f"readout must be a fraction in (0, 1], not {self.readout!r}")
        # As the command line will say it, so that the page's frame is the command's.
        object.__setattr__(self, "readout", round(float(self.readout), 4))
        if self.direction not in DIRECTIONS:
            raise SettingsError(f"direction must be one of {', '.join(DIRECTIONS)}")
        if self.reference not in REFERENCES:
            raise SettingsError(f"reference must be one of {', '.join(REFERENCES)}")

    @classmethod
    def from_query(cls, query: Mapping[str, str], base: PreviewSettings) -> PreviewSettings:
        """Read settings from URL query parameters, ``base`` for those not given."""
        def number(name: str, default: float) -> float:
            text = query.get(name)
            if text is None:
                return default
            try:
                return float(text)
            except ValueError:
                raise SettingsError(f"{name} must be a number, not {text!r}") from None

        flag = query.get("camera_only")
        return cls(method=query.get("method", base.method),
                   readout=number("readout", base.readout),
                   direction=query.get("direction", base.direction),
                   reference=query.get("reference", base.reference),
                   camera_only=base.camera_only if flag is None else flag in ("1", "true"))

    def options(self) -> dict[str, Any]:
        """Return the settings as :data:`unjello.config.OPTIONS` names (a preset's keys).

        Vibration is off: the preview sees a few frames, too few for ``auto`` to decide
        as the whole clip would.
        """
        opts: dict[str, Any] = {"method": self.method, "readout": self.readout,
                                "direction": self.direction, "reference": self.reference}
        if self.method == "dense":
            opts["vibration"] = "off"
            if self.camera_only:
                opts["camera_only"] = True
        return opts

    def timing(self) -> SensorTiming:
        """Return the :class:`~unjello.timing.SensorTiming` of these settings."""
        return SensorTiming(self.readout, cast(Direction, self.direction),
                            cast(Reference, self.reference))

    def config(self, base: CorrectionConfig = CorrectionConfig()) -> CorrectionConfig:
        """Return the :class:`~unjello.config.CorrectionConfig` of ``base`` with these."""
        return base.with_options(origin="preview", **self.options())

    def command(self, src: str, output: str) -> str:
        """Return the ``unjello correct`` line that gives these settings' frames."""
        parts = ["unjello", "correct", src, "-o", output]
        for name, value in self.options().items():
            flag = "--" + name.replace("_", "-")
            parts += [flag] if value is True else [flag, str(value)]
        return " ".join(shlex.quote(p) for p in parts)


class PreviewClip:
    """A clip held for previewing: its frames, and corrections of one frame at a time.

    Parameters
    ----------
    src : path-like
        A video or a folder of frames.
    config : CorrectionConfig
        The starting settings (the command line's): readout, direction, reference,
        method, as ``unjello correct`` would resolve them.
    max_frames : int
        Frames held (from the start).

    Raises
    ------
    InputError
        If the clip cannot be read or has fewer than two frames.
    """

    def __init__(self, src: str | os.PathLike, config: CorrectionConfig = CorrectionConfig(),
                 max_frames: int = 1800) -> None:
        self.src = Path(src)
        if not self.src.exists():
            raise InputError(f"{self.src}: no such file or folder")
        if config.method not in PREVIEW_METHODS:
            config = dataclasses.replace(config, method="dense")
        with FrameSource(self.src) as source:
            info = source.info
            # As `correct` decides them: the timing, and the lens (for undistorting).
            config, resolved, *_ = resolve_clip(config, self.src, source)
        self.base = config
        self._dir = tempfile.TemporaryDirectory(prefix="unjello-preview-")
        # The part asked for (start=, duration=), and up to _AROUND frames either side of
        # it for the motion's windows; the page numbers the part's frames from 0.
        span = config.span
        begin = span.first_frame(resolved.fps)
        want = int(min(max_frames, span.length(resolved.fps)))
        self._pre = min(begin, _AROUND)
        held = 0
        shape: tuple[int, ...] = ()
        first: list[np.ndarray] = []  # for the readout estimate, read once
        for i, img in enumerate(read_frames(self.src)):
            if i < begin - self._pre:
                continue
            if held >= self._pre + want + (_AROUND if not span.whole else 0):
                break
            write_image(Path(self._dir.name) / f"{held:06d}.png", img)
            shape = img.shape
            if len(first) < _ESTIMATE_FRAMES:
                first.append(img)
            held += 1
        self._held = held
        self.count = max(0, min(held - self._pre, want))
        if held <= self._pre and begin:
            self._dir.cleanup()
            raise InputError(f"{self.src}: start={span.start} is past the clip's end")
        if self.count < 2:
            self._dir.cleanup()
            raise InputError(f"{self.src}: the preview needs at least two frames")
        self.truncated = (info.frames > begin + self.count if info.frames and span.duration
                          is None else False)
        self.height, self.width = int(shape[0]), int(shape[1])
        self.is_video = info.is_video
        self.fps = resolved.fps
        self.resolved = resolved
        # What the footage says of the readout, marked on the page's slider.
        self.estimate = resolved.estimate or estimate_readout(
            first, direction=resolved.timing.direction, max_frames=_ESTIMATE_FRAMES)
        self.initial = PreviewSettings(config.method, float(resolved.timing.readout),
                                       resolved.timing.direction, resolved.timing.reference,
                                       not config.dense.per_pixel)
        self._frames: _LRU = _LRU(2 * _AROUND + 4)
        self._flows: _LRU = _LRU(64)
        self._motions: dict[PreviewSettings, dict[int, FrameMotion]] = {}
        self._lock = threading.Lock()

    def close(self) -> None:
        """Remove the frames held on disk."""
        self._dir.cleanup()

    def __enter__(self) -> PreviewClip:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def frame(self, n: int) -> np.ndarray:
        """Return frame ``n`` as read (RGB, or grey for a grey folder)."""
        if not 0 <= n < self.count:
            raise InputError(f"no frame {n}: the clip has frames 0 to {self.count - 1}")
        return self._stored(n + self._pre)

    def _stored(self, k: int) -> np.ndarray:
        """Return the ``k``-th frame held (those around the part asked for included)."""
        img = self._frames.get(k)
        if img is None:
            img = read_image(Path(self._dir.name) / f"{k:06d}.png")
            self._frames[k] = img
        return img

    def corrected(self, n: int, settings: PreviewSettings) -> tuple[np.ndarray, float]:
        """Return frame ``n`` corrected with ``settings``, and the seconds it took."""
        if not 0 <= n < self.count:
            raise InputError(f"no frame {n}: the clip has frames 0 to {self.count - 1}")
        t0 = time.perf_counter()
        config = settings.config(self.base)
        timing = settings.timing()
        # Near the clip's ends the methods' windows shift inwards: keep the window's length.
        m = n + self._pre  # among the frames held
        lo = max(0, min(m - _AROUND, self._held - 1 - 2 * _AROUND))
        hi = min(self._held - 1, max(m + _AROUND, 2 * _AROUND))
        with self._lock:
            corrector = Corrector(timing, config, fps=self.fps, flows=self._flows,
                                  only={m - lo})
            out: np.ndarray | None = None
            for k in range(lo, hi + 1):
                done = corrector.push([self._stored(k)], float(k))
                if k == hi:
                    done += corrector.flush()
                for planes, fm in done:
                    if fm.index == m - lo:
                        out = planes[0]
                        self._motions.setdefault(settings, {})[n] = _frame_of(fm, n)
        assert out is not None
        return out, time.perf_counter() - t0

    def motions(self, settings: PreviewSettings) -> Trajectory:
        """Return the motion of the frames corrected so far with ``settings``, in order."""
        traj = Trajectory(settings.timing(), (self.width, self.height),
                          method=settings.method)
        done = self._motions.get(settings, {})
        traj.frames.extend(done[k] for k in sorted(done))
        return traj

    def info(self) -> dict[str, Any]:
        """Return what the page shows of the clip: size, frames, rate, readout's source."""
        return {"input": str(self.src), "frames": self.count, "truncated": self.truncated,
                "width": self.width, "height": self.height, "fps": self.fps,
                "settings": self.initial.options(),
                "readout_source": self.resolved.sources.get("readout", ""),
                "readout_estimate": self.estimate.as_json(costs=False),
                "messages": list(self.resolved.messages),
                "methods": list(PREVIEW_METHODS), "directions": list(DIRECTIONS),
                "references": list(REFERENCES)}

    def command(self, settings: PreviewSettings) -> str:
        """Return the ``unjello correct`` line for ``settings``."""
        out = (self.src.with_name(self.src.stem + "_unjello" + self.src.suffix)
               if self.is_video else self.src.with_name(self.src.name + "_unjello"))
        line = settings.command(str(self.src), str(out))
        span = self.base.span  # the part held: the command writes the same frames
        for flag, value in (("--start", span.start), ("--duration", span.duration)):
            if value is not None:
                line += f" {flag} {value}"
        return line

    def preset(self, settings: PreviewSettings) -> str:
        """Return a JSON preset file of ``settings`` (``unjello correct --preset FILE``)."""
        return json.dumps(settings.options(), indent=2) + "\n"


def _frame_of(fm: FrameMotion, n: int) -> FrameMotion:
    """Return the frame's motion, light, under its index in the clip."""
    return FrameMotion(n, float(n), fm.displacement, fm.velocity, ok=fm.ok, note=fm.note)


def encode_png(image: np.ndarray) -> bytes:
    """Return PNG bytes of an RGB or grey image, uncompressed (for this machine's browser).

    Compression would cost more than the correction: a 1080p frame took 0.36 s at
    zlib level 1, 0.09 s stored.
    """
    img = image if image.ndim == 2 else cv2.cvtColor(np.ascontiguousarray(image[..., :3]),
                                                     cv2.COLOR_RGB2BGR)
    ok, buf = cv2.imencode(".png", img, [cv2.IMWRITE_PNG_COMPRESSION, 0])
    if not ok:
        raise SettingsError("could not encode the frame as PNG")
    return bytes(buf)
