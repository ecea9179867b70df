"""A simulated clip written to disk: its rolling-shutter video, its truth, its motion."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io.frames import read_image
from ..io.sidecars import write_gyro
from ..io.sink import FrameSink, check_new, replace, temp_path
from ..io.video import VIDEO_SUFFIXES, EncodeOptions, VideoReader
from ..timing import SensorTiming
from ..trajectory import Trajectory
from .motion import gyro_samples, motion_from_spec
from .render import simulate

__all__ = ["read_scene", "simulate_clip"]

def read_scene(path: str | os.PathLike) -> tuple[Callable[[int], np.ndarray] | np.ndarray,
                                                     float | None]:
    """Open a simulation source: an image, or a video read frame by frame in order.

    Returns
    -------
    scene : ndarray or callable
        The image, or ``scene(n)`` returning video frame ``n`` (sequential access; the
        last frame repeats past the end).
    fps : float or None
        The video's frame rate.
    """
    p = Path(path)
    if not p.exists():
        raise InputError(f"{p}: no such file")
    if p.suffix.lower() not in VIDEO_SUFFIXES:
        return read_image(p), None
    reader = VideoReader(p)
    frames = reader.rgb_frames()
    state: dict = {"n": -1, "img": None}

    def scene(n: int) -> np.ndarray:
        while state["n"] < n:
            nxt = next(frames, None)
            if nxt is None:
                if state["img"] is None:
                    raise InputError(f"{p}: the video has no frames")
                break
            state["n"] += 1
            state["img"] = nxt
        return state["img"]

    return scene, reader.info.fps


def simulate_clip(source: str | os.PathLike, rolling_out: str | os.PathLike,
                  truth_out: str | os.PathLike, *, motion: str = "pan",
                  timing: SensorTiming = SensorTiming(), frames: int = 30,
                  fps: float | None = None, size: tuple[int, int] | None = None,
                  speed: float = 8.0, amplitude: float = 1.0, exposure: float = 0.0,
                  overwrite: bool = False, truth_motion: str | os.PathLike | None = None,
                  encode: EncodeOptions = EncodeOptions(),
                  gyro_out: str | os.PathLike | None = None) -> Trajectory:
    """Render a rolling-shutter clip and its global-shutter truth to files.

    Parameters
    ----------
    source : path-like
        A still image (panned over) or a global-shutter video.
    rolling_out, truth_out : path-like
        Outputs: video files (``.mp4`` ...) or folders of PNG frames.
    motion : str
        A motion name of :data:`unjello.simulate.MOTIONS` or a JSON file.
    timing : SensorTiming
        Readout, direction, reference.
    frames : int
        Number of frames.
    fps : float, optional
        Frame rate (default: the source video's, else 30).
    size : tuple of int, optional
        Output ``(width, height)``.
    speed, amplitude, exposure : float
        See :class:`unjello.simulate.Motion` and :func:`unjello.simulate.simulate`.
    overwrite : bool
        Replace existing outputs.
    truth_motion : path-like, optional
        Where to write the true trajectory (default ``<truth_out>.motion.json``).
    encode : EncodeOptions
        Encoder settings of video outputs.
    gyro_out : path-like, optional
        Also write a 400 Hz gyroscope log of the motion (CSV: time in s from the first
        frame, then rad/s about x, y, z), as from a lens of 8 times the frame's width
        (:func:`unjello.simulate.gyro_samples`).

    Returns
    -------
    Trajectory
        The true per-scanline motion.
    """
    check_new(gyro_out, overwrite)

    scene, src_fps = read_scene(source)
    fps = float(fps or src_fps or 30.0)
    mot = motion_from_spec(motion, fps=fps, speed=speed, amplitude=amplitude, n_frames=frames)
    truth_motion = Path(truth_motion or f"{truth_out}.motion.json")
    traj: Trajectory | None = None
    with FrameSink(rolling_out, fps, overwrite, encode) as rs_sink, \
            FrameSink(truth_out, fps, overwrite, encode) as gs_sink:
        for sf in simulate(scene, mot, timing, frames, size=size, exposure=exposure):
            if traj is None:
                h, w = sf.rolling.shape[:2]
                traj = Trajectory(timing, (w, h), method="truth")
            rs_sink.write(sf.rolling)
            gs_sink.write(sf.truth)
            traj.frames.append(sf.motion)
    assert traj is not None
    traj.save(truth_motion)
    if gyro_out is not None:
        t, rates = gyro_samples(mot, 8.0 * traj.size[0], frames / fps)
        tmp = temp_path(Path(gyro_out))
        write_gyro(tmp, t, rates)
        replace(tmp, Path(gyro_out))
    return traj
