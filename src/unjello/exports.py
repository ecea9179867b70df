"""Exports that read the Trajectory: STMaps for compositing apps, and motion plots."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .io.frames import write_image
from .timing import SensorTiming
from .trajectory import FrameMotion, Trajectory
from .warp import field_maps, remap_maps, resize_maps

__all__ = ["backward_maps", "maps_to_coded", "stmap_image", "stmap_to_maps", "write_stmap",
           "plot_trajectory"]


def backward_maps(motion: FrameMotion, width: int) -> tuple[np.ndarray, np.ndarray]:
    """Source position of every output pixel (top-bottom orientation), as the warper uses."""
    if motion.field is not None:
        h = motion.displacement.shape[0]
        return resize_maps(*field_maps(motion.field, frame=(h, width)), h, width)
    return remap_maps(motion.displacement, width)


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


def stmap_to_maps(stmap: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Decode :func:`stmap_image` back into ``cv2.remap`` maps."""
    h, w = stmap.shape[:2]
    st = stmap[..., :2].astype(np.float64) / 65535.0
    map_x = st[..., 0] * w - 0.5
    map_y = (1.0 - st[..., 1]) * h - 0.5
    return map_x.astype(np.float32), map_y.astype(np.float32)


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


def plot_trajectory(traj: Trajectory, output: str | os.PathLike) -> None:
    """Plot per-scanline displacement and velocity over time, like the paper's Fig. 6.

    Each frame's scanlines are drawn at their imaging times ``t_n + rho r / h``; dashed
    lines mark the frame starts.

    Parameters
    ----------
    traj : Trajectory
        The motion to plot.
    output : path-like
        PNG (or any format Matplotlib writes).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 1, figsize=(10, 6), sharex=True, constrained_layout=True)
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
    axes[1].set_xlabel("time (frame intervals); dashed: frame starts")
    axes[0].legend(loc="upper right")
    axes[0].set_title(f"unjello motion ({traj.method or 'unknown method'}): readout "
                      f"{traj.timing.readout:.3f} of the frame interval, "
                      f"{traj.timing.direction}, reference {traj.timing.reference}, "
                      f"{len(traj)} frames")
    for ax in axes:
        ax.grid(alpha=0.3)
    fig.savefig(str(output), dpi=110)
    plt.close(fig)
