"""One picture at a time: the motion method, the breaks between stretches, the warp.

A :class:`Corrector` takes pictures in order and gives them back corrected, a fixed
number of frames later: it decides where the clip breaks (:mod:`unjello.motion.cuts`,
one picture late), gives each stretch a motion method of its own (the paper's, the dense
one, the gyro's, or a given motion), stabilises if asked, and warps every plane of each
picture by its motion (:class:`~unjello.warp.warper.PictureWarper`). The streaming drivers in
:mod:`unjello.pipeline`, the preview, the segments and the VapourSynth filter all use it.
"""

from __future__ import annotations

import dataclasses
import functools
from collections import deque
from collections.abc import MutableMapping, Sequence
from concurrent.futures import Executor

import cv2
import numpy as np

from .config import CorrectionConfig
from .errors import InputError, SettingsError
from .gyrolog import GyroLog
from .io.sidecars import read_gyro
from .lens import Lens
from .motion.cuts import Breaks
from .motion.dense.method import DenseMethod
from .motion.gyro.fallback import GyroOrDense
from .motion.paper.method import PaperMethod
from .motion.replay import Replay
from .stabilize import Stabilizer, track, tracking_copy
from .timing import SensorTiming, to_top_bottom
from .trajectory import FrameMotion, Stretch, Trajectory
from .warp.warper import PictureWarper

__all__ = ["Corrector"]


def _luma255(image: np.ndarray, max_value: float) -> np.ndarray:
    """Grey 0-255 of a plane or colour image; 8-bit luma is passed through as is."""
    if image.ndim == 2 and image.dtype == np.uint8 and max_value == 255:
        return image  # the methods convert after their own downscaling
    img = image
    if img.ndim == 3:
        rgb = img[..., :3]
        if rgb.dtype not in (np.uint8, np.uint16, np.float32):
            rgb = rgb.astype(np.float32)
        img = cv2.cvtColor(np.ascontiguousarray(rgb), cv2.COLOR_RGB2GRAY)
    return img.astype(np.float32) * np.float32(255.0 / max_value)


def _max_value(dtype: np.dtype) -> float:
    if np.issubdtype(dtype, np.integer):
        return float(np.iinfo(dtype).max)
    return 1.0


class Corrector:
    """Correct pictures one at a time with bounded look-ahead.

    A *picture* is a list of planes in coded orientation; the first is the luma (or a
    colour image) and drives the motion estimate; every plane is warped by the same
    displacement (:class:`~unjello.warp.warper.PictureWarper`).

    Parameters
    ----------
    timing : SensorTiming
        Readout, direction and reference.
    config : CorrectionConfig
        Method and warp.
    max_value : float, optional
        White level of the first plane (255 for 8 bit, 1023 for 10 bit); default from
        the dtype.
    motion : Trajectory, optional
        Apply this motion (e.g. from ``motion_in``) instead of estimating it.
    fps : float
        Frame rate, for the gyro method.
    gyro_log : GyroLog, optional
        The gyro method's samples (default: read from ``config.gyro.path``).
    flows : mutable mapping, optional
        The dense method's flows between frame pairs, kept across correctors of the same
        frames (:class:`~unjello.motion.dense.method.DenseMethod`).
    only : set of int, optional
        Warp only these frames (by index from the first pushed); the others come back as
        they were read, with their motion (the preview wants one frame of a window).
    gyro_fallback : bool or str
        With the gyro method, what a gyro that does not fit the picture leads to
        (:class:`~unjello.motion.gyro.fallback.GyroOrDense`): False, an error; True, the
        dense method; a string, the dense method even if it fits (the reason).
    executor : concurrent.futures.Executor, optional
        Threads that measure the next frames' flows meanwhile
        (:func:`unjello.run.parallel.frame_threads`); the result is the same.
    workers : int
        The executor's threads (that many frame pairs are measured ahead).

    Attributes
    ----------
    method : str
        The method that measures the motion (``'dense'`` after a fallback).
    """

    def __init__(self, timing: SensorTiming, config: CorrectionConfig = CorrectionConfig(),
                 max_value: float | None = None, motion: Trajectory | None = None,
                 fps: float = 30.0, gyro_log: GyroLog | None = None,
                 flows: MutableMapping[tuple, tuple] | None = None,
                 only: set[int] | None = None, gyro_fallback: bool | str = False,
                 executor: Executor | None = None, workers: int = 2) -> None:
        self.timing = timing
        self.config = config
        self.max_value = max_value
        self._method: PaperMethod | DenseMethod | GyroOrDense | Replay
        if motion is not None:
            self._method = Replay(motion)
        elif config.method == "gyro":
            if gyro_log is None:
                if not config.gyro.path:
                    raise InputError("the gyro method needs a gyro log: give gyro=FILE")
                gyro_log = read_gyro(config.gyro.path, config.gyro.layout, config.gyro.units)
            self._method = GyroOrDense(timing, gyro_log, config.gyro, config.dense, fps,
                                       flows, gyro_fallback)
        self._make = functools.partial(  # a method measuring the footage: new each stretch
            PaperMethod, timing, config.paper) if config.method == "paper" else (
            functools.partial(DenseMethod, timing, config.dense, flows, executor, workers))
        # Cuts, flashes and size changes end a stretch of the footage (the methods that
        # measure it: a gyro or a given motion describes the whole clip).
        self._breaks = Breaks() if config.method in ("paper", "dense") and motion is None \
            else None
        if self._breaks is not None:
            self._method = self._make()
        #: The stretches so far: where each starts, why, and the model its motion took.
        self.stretches: list[Stretch] = []
        self._first = 0  # the current stretch's first picture
        # The picture read last, until the next tells whether the clip breaks before it.
        self._pending: tuple[list[np.ndarray], np.ndarray, float] | None = None
        lens = None
        if config.undistort:
            if config.gyro.focal is None or config.gyro.distortion is None:
                raise SettingsError("undistort needs the lens: lens_profile=, camera= (a "
                                    "camera the database has a lens for), or focal= with "
                                    "distortion=")
            lens = Lens(config.gyro.focal, config.gyro.distortion)
        self.warp = PictureWarper(timing, config.warp, config.fill, undistort=lens)
        self.fps = fps
        self._stabilizer: Stabilizer | None = None
        # The previous frame's tracking copy, when stabilising.
        self._luma: tuple[np.ndarray, float] | None = None
        self._count = 0  # pictures pushed
        self._only = only
        self._held: deque[list[np.ndarray]] = deque()
        # The pictures before the next one held, as read: as many as the warp reads.
        self._before: deque[list[np.ndarray]] = deque(maxlen=PictureWarper.REACH)

    def push(self, planes: Sequence[np.ndarray], start: float, joined: str | None = None
             ) -> list[tuple[list[np.ndarray], FrameMotion]]:
        """Add a picture whose first scanline starts at ``start`` (frame intervals).

        ``joined``: the reader found two streams joined before it (``'size'``: another
        picture size, scaled; ``'time'``: timestamps that started over), a break
        (:mod:`unjello.motion.cuts`). At a break the pictures held are corrected as a
        clip's last, and a new stretch starts with this one.

        Returns
        -------
        list of (planes, FrameMotion)
            Pictures now corrected, in order.
        """
        planes = list(planes)
        mv = self.max_value or _max_value(planes[0].dtype)
        luma = _luma255(to_top_bottom(planes[0], self.timing.direction), mv)
        if self._breaks is None:
            return self._feed(planes, luma, start)
        # Whether the clip breaks before a picture is decided with the picture after it.
        self._breaks.add(luma, joined)
        done = []
        if self._pending is not None:
            done = self._feed(*self._pending, why=self._breaks.before(2))
        self._pending = (planes, luma, start)
        return done

    def _feed(self, planes: list[np.ndarray], luma: np.ndarray, start: float,
              why: str | None = None) -> list[tuple[list[np.ndarray], FrameMotion]]:
        """Give a picture to the method (after ending the stretch if ``why``), warp what is out."""
        done = []
        if why is not None:
            done = self._end_stretch()
        if self._breaks is not None and (why is not None or not self._count):
            self.stretches.append(Stretch(self._count, why or "start",
                                          dict(self._breaks.evidence)))
        self._held.append(planes)
        motions = self._renumber(self._method.push(luma, start))
        if self.config.stabilize.enabled:
            if self._stabilizer is None:
                self._stabilizer = Stabilizer(self.config.stabilize, self.timing,
                                              (luma.shape[1], luma.shape[0]), self.fps)
            tracks = {}
            gyro = self.gyro
            if gyro is not None and gyro.method == "gyro" and gyro.agreement is not None:
                self._luma = None  # calibrated and used: its poses give every step
            else:
                small = tracking_copy(luma)
                if self._luma is not None:  # steps and roll, from points tracked across frames
                    tracks[self._count] = track(self._luma, small)
                self._luma = small
            motions = self._stabilizer.push(motions, tracks, self._poses(motions))
        self._count += 1
        return done + self._apply(motions)

    def _renumber(self, motions: list[FrameMotion]) -> list[FrameMotion]:
        """Return a stretch's frames numbered from the clip's start."""
        if not self._first:
            return motions
        return [dataclasses.replace(fm, index=fm.index + self._first) for fm in motions]

    def _end_stretch(self) -> list[tuple[list[np.ndarray], FrameMotion]]:
        """Correct the pictures held as a clip's last; start a new method and stabiliser."""
        done = self._drain()
        if self.stretches:
            self.stretches[-1] = self.stretches[-1].ended(self._count - 1, self._method)
        self._method, self._first = self._make(), self._count
        self._stabilizer, self._luma = None, None
        self._before.clear()
        return done

    @property
    def pushed(self) -> int:
        """Pictures pushed so far (those read around a part of the clip too)."""
        return self._count

    @property
    def method(self) -> str:
        """The method that measures the motion (``'dense'`` after a gyro's fallback)."""
        if isinstance(self._method, GyroOrDense):
            return self._method.method
        return "replay" if isinstance(self._method, Replay) else self.config.method

    @property
    def vibration(self) -> float | None:
        """The dense method's detected vibration (its wobble), if ``auto`` switched it on.

        The first stretch's that vibrated, or the current one's.
        """
        found = [s.wobble for s in self.stretches if s.wobble is not None]
        return found[0] if found else getattr(self._method, "wobble", None)

    def close_stretches(self) -> list[Stretch]:
        """Return the stretches, the last one ended (call after :meth:`flush`)."""
        if self.stretches and self.stretches[-1].last < 0:
            self.stretches[-1] = self.stretches[-1].ended(self._count - 1, self._method)
        return self.stretches

    @property
    def gyro(self) -> GyroOrDense | None:
        """The gyro method and what became of it (None for the other methods)."""
        return self._method if isinstance(self._method, GyroOrDense) else None

    def _poses(self, motions: list[FrameMotion]) -> dict[int, np.ndarray]:
        """Return the gyro's pose of each frame for the stabiliser (none from other methods)."""
        if self.gyro is None:
            return {}
        poses = {fm.index: self.gyro.pose(fm.start) for fm in motions}
        return {k: p for k, p in poses.items() if p is not None}

    def flush(self) -> list[tuple[list[np.ndarray], FrameMotion]]:
        """Correct the pictures still held at the end of the clip."""
        done = []
        if self._pending is not None:
            assert self._breaks is not None
            done = self._feed(*self._pending, why=self._breaks.before(1))
            self._pending = None
        return done + self._drain()

    def _drain(self) -> list[tuple[list[np.ndarray], FrameMotion]]:
        """Correct every picture the method holds: the end of a stretch."""
        motions = self._renumber(self._method.flush())
        if self._stabilizer is not None:
            motions = (self._stabilizer.push(motions, poses=self._poses(motions))
                       + self._stabilizer.flush())
        return self._apply(motions)

    def _apply(self, motions: list[FrameMotion]) -> list[tuple[list[np.ndarray], FrameMotion]]:
        out = []
        for fm in motions:
            planes = self._held.popleft()
            reach = range(1, PictureWarper.REACH + 1)
            around = {**{-k: self._before[-k] if len(self._before) >= k else None
                         for k in reach},
                      **{k: self._held[k - 1] if len(self._held) >= k else None for k in reach}}
            skip = self._only is not None and fm.index not in self._only
            if skip:
                out.append((planes, fm))
            else:
                warped = self.warp(planes, fm, around)
                out.append((warped, dataclasses.replace(fm, diagnostics=dataclasses.replace(
                    fm.diagnostics, unseen=self.warp.unseen))))
            self._before.append(planes)
        return out
