"""Exports that read the Trajectory: STMaps, motion plots, side-by-side views, side outputs.

:class:`SideOutputs` writes, while a clip is corrected, what a user asked for beside the
corrected clip: the motion JSON, one STMap per frame, and a side-by-side preview video.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import BinaryIO

import cv2
import numpy as np

from ..io.frames import rgb8, write_image
from ..io.sink import FrameSink, make_folder, remove, replace, temp_path
from ..io.source import FrameSource
from ..io.video import EncodeOptions, VideoWriter
from ..timing import SensorTiming
from ..trajectory import FrameMotion, Trajectory, TrajectoryWriter
from ..warp.maps import frame_maps, resize_maps

__all__ = ["backward_maps", "maps_to_coded", "stmap_image", "write_stmap",
           "plot_trajectory", "side_by_side", "side_by_side_planes", "SideOutputs"]


def backward_maps(motion: FrameMotion, width: int) -> tuple[np.ndarray, np.ndarray]:
    """Source position of every output pixel (top-bottom orientation), as the warper uses.

    The whole warp: the correction and, when stabilised, the frame's reframe.
    """
    h = motion.displacement.shape[0]
    maps, coarse = frame_maps(motion, h, width)
    return resize_maps(*maps, h, width) if coarse else maps


def maps_to_coded(map_x: np.ndarray, map_y: np.ndarray, direction: str
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Turn top-bottom backward maps into maps of the frame in coded orientation.

    Parameters
    ----------
    map_x, map_y : ndarray of shape (h, w)
        For each pixel of the top-bottom frame, the source position in that frame.
    direction : str
        Scan direction (see :func:`unjello.timing.to_top_bottom`).

    Returns
    -------
    map_x, map_y : ndarray
        Same, for the coded frame: output pixel ``(X, Y)`` samples ``(map_x, map_y)``.
    """
    h, w = map_x.shape  # top-bottom shape
    if direction == "top-bottom":
        return map_x, map_y
    if direction == "bottom-top":
        return map_x[::-1].copy(), (h - 1 - map_y)[::-1].copy()
    if direction == "left-right":
        return map_y.T.copy(), map_x.T.copy()
    if direction == "right-left":
        # tb[y, x] = coded[x, W - 1 - y] with W = h.
        return (h - 1 - map_y)[::-1].T.copy(), map_x[::-1].T.copy()
    raise ValueError(f"unknown direction {direction!r}")


def stmap_image(map_x: np.ndarray, map_y: np.ndarray) -> np.ndarray:
    """Encode backward maps as a 16-bit STMap (R = s, G = t, B = 0).

    ``s = (x + 0.5) / width`` and ``t = 1 - (y + 0.5) / height`` of the source position,
    pixel centres, as Nuke, Resolve/Fusion and After Effects read STMaps.
    """
    h, w = map_x.shape
    s = (map_x + 0.5) / w
    t = 1.0 - (map_y + 0.5) / h
    rgb = np.stack([s, t, np.zeros_like(s)], axis=-1)
    return np.clip(np.rint(rgb * 65535.0), 0, 65535).astype(np.uint16)


def write_stmap(folder: str | os.PathLike, motion: FrameMotion, timing: SensorTiming,
                coded_size: tuple[int, int]) -> Path:
    """Write ``stmap_NNNNNN.png`` (16-bit RGB) for one frame into ``folder``.

    Parameters
    ----------
    folder : path-like
        Existing folder.
    motion : FrameMotion
        The frame's motion.
    timing : SensorTiming
        For the scan direction.
    coded_size : tuple of int
        ``(width, height)`` of the frame in coded orientation.

    Returns
    -------
    Path
        The file written.
    """
    w, h = coded_size
    tb_width = w if timing.direction in ("top-bottom", "bottom-top") else h
    mx, my = backward_maps(motion, tb_width)
    mx, my = maps_to_coded(mx, my, timing.direction)
    path = Path(folder) / f"stmap_{motion.index:06d}.png"
    write_image(path, stmap_image(mx, my))
    return path


def plot_trajectory(traj: Trajectory, output: str | os.PathLike | BinaryIO,
                    mark: float | None = None) -> None:
    """Plot per-scanline displacement and velocity over time, like the paper's Fig. 6.

    Each frame's scanlines are drawn at their imaging times ``t_n + rho r / h``; dashed
    lines mark the frame starts. A stabilised motion gets a third panel: the camera's
    path the stabiliser measured and the smoothed one the output shows.

    Parameters
    ----------
    traj : Trajectory
        The motion to plot.
    output : path-like or binary file
        PNG (or any format Matplotlib writes, by the file's suffix); a file gets a PNG.
    mark : float, optional
        A time to mark (the frame the preview shows).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    stabilised = any(not f.reframe.identity for f in traj.frames)
    fig, axes = plt.subplots(3 if stabilised else 2, 1, figsize=(10, 9 if stabilised else 6),
                             sharex=True, constrained_layout=True)
    colors = {"x": "tab:blue", "y": "tab:orange"}
    for i, f in enumerate(traj.frames):
        h = f.displacement.shape[0]
        t = traj.timing.row_times(h, f.start)
        for k, name in enumerate("xy"):
            label = f"{name}" if i == 0 else None
            axes[0].plot(t, f.displacement[:, k], color=colors[name], lw=1.2, label=label)
            axes[1].plot(t, f.velocity[:, k], color=colors[name], lw=1.2, label=label)
        for ax in axes:
            ax.axvline(f.start, color="0.7", lw=0.6, ls="--")
    axes[0].set_ylabel("displacement from the\nreference scanline (px)")
    axes[1].set_ylabel("velocity (px / frame)")
    if stabilised:
        h = traj.frames[0].displacement.shape[0]
        t_ref = [traj.timing.reference_time(h, f.start) for f in traj.frames]
        actual = np.array([f.reframe.path[:2] for f in traj.frames])
        shown = actual + np.array([f.reframe.shift for f in traj.frames])
        for k, name in enumerate("xy"):
            axes[2].plot(t_ref, actual[:, k], color=colors[name], lw=1.0, label=f"{name}")
            axes[2].plot(t_ref, shown[:, k], color=colors[name], lw=2.0, ls="--",
                         label=f"{name}, stabilised")
        axes[2].set_ylabel("camera path at the\nreference times (px)")
        axes[2].legend(loc="upper right")
    if mark is not None:
        for ax in axes:
            ax.axvline(mark, color="tab:red", lw=1.5)
    axes[-1].set_xlabel("time (frame intervals); dashed: frame starts"
                        + ("; red: the frame shown" if mark is not None else ""))
    axes[0].legend(loc="upper right")
    axes[0].set_title(f"unjello motion ({traj.method or 'unknown method'}): readout "
                      f"{traj.timing.readout:.3f} of the frame interval, "
                      f"{traj.timing.direction}, reference {traj.timing.reference}, "
                      f"{len(traj)} frames")
    for ax in axes:
        ax.grid(alpha=0.3)
    fig.savefig(output if hasattr(output, "write") else str(output), dpi=110,
                format=None if isinstance(output, (str, os.PathLike)) else "png")
    plt.close(fig)


def side_by_side(before: np.ndarray, after: np.ndarray, labels: tuple[str, str] = (
        "rolling shutter", "unjello")) -> np.ndarray:
    """Put two RGB frames next to each other with a divider and labels."""
    h = before.shape[0]
    bar = np.full((h, 4, 3), 255, np.uint8)
    out = np.hstack([before[..., :3], bar, after[..., :3]]).copy()
    for x, text in ((8, labels[0]), (before.shape[1] + 12, labels[1])):
        cv2.putText(out, text, (x, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (0, 0, 0), 4,
                    cv2.LINE_AA)
        cv2.putText(out, text, (x, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (255, 255, 255), 1,
                    cv2.LINE_AA)
    return out


def side_by_side_planes(before: list[np.ndarray], after: list[np.ndarray]
                        ) -> list[np.ndarray]:
    """Input and output planes next to each other with a 4-pixel white divider."""
    out = []
    w0 = before[0].shape[1]
    for i, (a, b) in enumerate(zip(before, after, strict=True)):
        div = max(1, 4 * a.shape[1] // w0)
        white = np.iinfo(a.dtype).max if i == 0 else (np.iinfo(a.dtype).max + 1) // 2
        bar = np.full((a.shape[0], div) + a.shape[2:], white, dtype=a.dtype)
        out.append(np.hstack([a, bar, b]))
    return out


class SideOutputs:
    """What is written beside the corrected clip, frame by frame, atomically.

    Parameters
    ----------
    motion_out : path-like, optional
        The motion JSON (:class:`~unjello.trajectory.TrajectoryWriter`).
    stmap : path-like, optional
        A folder of per-frame STMaps (:func:`write_stmap`).
    preview : path-like, optional
        A side-by-side video, input left, corrected right: in the input's own format,
        timing and rotation for a video source, RGB for a folder.
    encode : EncodeOptions
        Encoder of the preview.
    """

    def __init__(self, motion_out: str | os.PathLike | None = None,
                 stmap: str | os.PathLike | None = None,
                 preview: str | os.PathLike | None = None,
                 encode: EncodeOptions = EncodeOptions()) -> None:
        self.motion_out = Path(motion_out) if motion_out is not None else None
        self.stmap = Path(stmap) if stmap is not None else None
        self.preview = Path(preview) if preview is not None else None
        self.encode = encode
        self._motion: TrajectoryWriter | None = None
        self._stmap_tmp: Path | None = None
        self._sink: FrameSink | None = None
        self._writer: VideoWriter | None = None
        self._preview_tmp: Path | None = None

    @property
    def paths(self) -> tuple[Path, ...]:
        """The outputs asked for."""
        return tuple(p for p in (self.motion_out, self.stmap, self.preview) if p is not None)

    def start(self, source: FrameSource, traj: Trajectory, fps: float) -> None:
        """Open the outputs for a clip whose trajectory header is ``traj``."""
        if self.motion_out is not None:
            self._motion = TrajectoryWriter(self.motion_out, traj)
        if self.stmap is not None:
            self._stmap_tmp = temp_path(self.stmap)
            make_folder(self._stmap_tmp)
        if self.preview is not None:
            if source.reader is not None:
                reader, info = source.reader, source.reader.info
                self._preview_tmp = temp_path(self.preview)
                self._writer = VideoWriter(
                    self._preview_tmp, size=(2 * info.width + 4, info.height), fps=info.fps,
                    time_base=info.time_base, pix_fmt=reader.work_format, options=self.encode,
                    rotation=info.rotation, color=info.color)
            else:
                self._sink = FrameSink(self.preview, fps, True, self.encode)

    def frame(self, before: list[np.ndarray], after: list[np.ndarray], fm: FrameMotion,
              timing: SensorTiming, pts: int | None = None) -> None:
        """Write one frame's side outputs."""
        if self._motion is not None:
            self._motion.write(fm)
        if self._stmap_tmp is not None:
            h, w = before[0].shape[:2]
            write_stmap(self._stmap_tmp, fm, timing, (w, h))
        if self._writer is not None:
            self._writer.write(side_by_side_planes(before, after), pts)
        elif self._sink is not None:
            self._sink.write(side_by_side(rgb8(before[0]), rgb8(after[0]),
                                          ("input", "unjello")))

    def finish(self) -> None:
        """Move every output into place."""
        if self._motion is not None:
            self._motion.close()
        if self._writer is not None and self._preview_tmp is not None and self.preview:
            self._writer.close()
            replace(self._preview_tmp, self.preview)
        if self._sink is not None:
            self._sink.close()
        if self._stmap_tmp is not None and self.stmap is not None:
            replace(self._stmap_tmp, self.stmap)

    def abort(self) -> None:
        """Drop every partial output."""
        if self._motion is not None:
            self._motion.abort()
        if self._writer is not None:
            self._writer.abort()
        if self._sink is not None:
            self._sink.abort()
        for tmp in (self._preview_tmp, self._stmap_tmp):
            if tmp is not None:
                remove(tmp)
