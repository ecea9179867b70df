"""The footage's own motion as a Gyroflow project: the rates a gyro would have logged.

Gyroflow and its editor plugins (OpenFX for DaVinci Resolve, Adobe for After Effects and
Premiere, frei0r) correct rolling shutter from a gyro. With the smoothing ``No smoothing``
every scanline ``y`` of the frame whose middle row is read at ``t_f`` is turned by the
camera's rotation between ``t_f`` and the row's own time ``t_y`` (Gyroflow's
``stabilization/frame_transform.rs``: ``q = O(t_f)^-1 O(t_y)``, ``O`` the orientation
integrated from the log). unjello measures that motion from the picture, per scanline:
the dense method's camera trajectory, the paper's per-scanline motion, or the gyro it
calibrated. This module turns a :class:`~unjello.trajectory.Trajectory` into the rates a
gyro on the camera would have logged, so that Gyroflow's rule reproduces unjello's own
per-row correction, and writes them as a ``.gcsv`` log beside a ``.gyroflow`` project.

**Per row, a rotation.** Row ``y`` of frame ``n`` is displaced by ``D(y)`` from where it
belongs at the reference time (eq. 26): the centre column's pixel ``s = (c_x, y)`` belongs
at ``p = s - D(y)``. The rotation ``A(y)`` with ``p ~ K A(y) K^-1 s`` (its roll given: the
stabiliser's, else none) is solved per row by Newton's method through the lens (a fisheye
rotates undistorted rays). The camera's orientation at the row's time is then
``C(t_y) = A(y)^T C(t_ref)``; between frames ``C(t_ref)`` moves by the camera path's step
(its integrated velocity, ``(-dc_y, dc_x) / f``, and the stabiliser's roll).

**Rates.** ``C`` is sampled evenly, ``SAMPLES_PER_READOUT`` times a readout at least, and
written as the rate of each step, ``log(C_k C_{k-1}^T) / dt``: integrating them as Gyroflow
does (``O_k = O_{k-1} exp(w dt)``) gives back ``C`` exactly, not only to first order.

**Axes.** The gcsv's columns are the rates about the camera's x (right), y (down) and z
(along the view) axes of the frame as it is coded. Gyroflow integrates ``(-g_y, g_x,
g_z)`` of its IMU axes ``g`` and flips x in its rotation matrix
(``frame_transform.rs``), so ``g = (w_y, w_x, w_z)``: the header's ``orientation`` is
``YXZ``. Its time 0 is the first frame's first scanline; Gyroflow takes a frame's time as
its middle row's and a log's first sample as its time 0, so the project's ``offsets``
hold minus half a readout.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import __version__
from ..clip import with_lens
from ..config import CorrectionConfig
from ..errors import SettingsError, cannot_write
from ..io.sink import check_new, remove, replace, temp_path
from ..io.telemetry import camera_of
from ..lens import Lens
from ..motion.gyro.fallback import GyroOrDense
from ..timing import SensorTiming, coded_axes
from ..trajectory import Trajectory

__all__ = ["ProjectLens", "SAMPLES_PER_READOUT", "GUESSED_FOV", "ORIENTATION",
           "camera_rates", "log_rates", "gcsv_text", "project", "write_gyroflow",
           "gcsv_path", "gyroflow_displacement", "export_project",
           "check_project", "project_lens", "clip_project"]

#: Rate samples per readout at least: one a frame would carry almost no rolling shutter.
SAMPLES_PER_READOUT = 32
#: Horizontal field of view taken for a lens no one states, degrees (a phone's main camera).
GUESSED_FOV = 70.0
#: Gyroflow's IMU axes from the gcsv's columns (the module notes).
ORIENTATION = "YXZ"
# Rows a frame's per-row rotation is solved on (then interpolated between them).
_ROWS = 65

_DIRECTION_CODES = {"top-bottom": "TopToBottom", "bottom-top": "BottomToTop",
                    "left-right": "LeftToRight", "right-left": "RightToLeft"}


@dataclass(frozen=True)
class ProjectLens:
    """The lens the rotations are taken through.

    Parameters
    ----------
    focal : float
        Focal length, pixels of the coded frame.
    k : tuple of 4 float, optional
        Fisheye distortion (OpenCV's model); None: a rectilinear lens.
    source : str
        Where it came from, in words.
    guessed : bool
        True when nothing stated it (:data:`GUESSED_FOV`).
    """

    focal: float
    k: tuple[float, ...] | None = None
    source: str = "given"
    guessed: bool = False

    @classmethod
    def guess(cls, width: int) -> ProjectLens:
        """Return a rectilinear lens of :data:`GUESSED_FOV` degrees across ``width`` pixels."""
        focal = width / 2 / math.tan(math.radians(GUESSED_FOV / 2))
        return cls(focal, None, f"guessed: {GUESSED_FOV:.0f} degrees across the width", True)

    def describe(self) -> str:
        """One line: focal length, distortion, where from."""
        kind = ("fisheye k " + ", ".join(f"{v:.3g}" for v in self.k)) if self.k else \
            "rectilinear"
        return f"focal {self.focal:.1f} px, {kind} ({self.source})"


def _project(phi: np.ndarray, rays: np.ndarray, lens: Lens, size: tuple[int, int]
             ) -> np.ndarray:
    """Pixels where ``rays`` (m, 3) land once turned by the rotation vectors ``phi``."""
    from scipy.spatial.transform import Rotation  # here: only exports need it

    q = Rotation.from_rotvec(phi).apply(rays)
    return lens.distort(q[:, :2] / np.maximum(q[:, 2:3], 1e-6), size)


def _row_turns(source: np.ndarray, target: np.ndarray, roll: np.ndarray, lens: Lens,
               size: tuple[int, int]) -> np.ndarray:
    """Rotation vectors ``(phi_x, phi_y, roll)`` taking pixels ``source`` to ``target``.

    Newton's method on the two pixel coordinates, ``phi_x`` and ``phi_y`` free, started
    from the first-order model ``p - s = f (phi_y, -phi_x (1 + r^2)) - (phi_z (y - c_y),
    0)`` (:func:`unjello.motion.gyro.method._row_model`).
    """
    h, w = size
    f, cy = lens.focal, (h - 1) / 2.0
    rays = np.concatenate([lens.undistort(source, size), np.ones((len(source), 1))], axis=1)
    d = target - source
    r2 = ((source[:, 1] - cy) / f) ** 2
    phi = np.stack([-d[:, 1] / (f * (1 + r2)), (d[:, 0] + roll * (source[:, 1] - cy)) / f,
                    roll], axis=1)
    eps = 1e-7
    for _ in range(4):
        at = _project(phi, rays, lens, size)
        jac = np.empty((len(source), 2, 2))
        for i in range(2):
            step = phi.copy()
            step[:, i] += eps
            jac[:, :, i] = (_project(step, rays, lens, size) - at) / eps
        delta = np.linalg.solve(jac, (target - at)[..., None])[..., 0]
        phi[:, :2] += delta
        if np.abs(delta).max() * f < 1e-6:
            break
    return phi


def camera_rates(traj: Trajectory, lens: ProjectLens, fps: float
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Return the angular rates that reproduce a trajectory's per-row camera motion (module notes).

    Parameters
    ----------
    traj : Trajectory
        The motion, per scanline (:attr:`~unjello.trajectory.FrameMotion.camera_displacement`
        and ``velocity``; the stabiliser's roll from ``reframe.path`` when present).
    lens : ProjectLens
        The lens, in pixels of the coded frame.
    fps : float
        The clip's frame rate (the unit of ``start`` is its frame interval).

    Returns
    -------
    time : ndarray of shape (n,)
        Seconds from the first frame's first scanline, evenly spaced from 0.
    rate : ndarray of shape (n, 3)
        Rad/s about the coded frame's camera axes (x right, y down, z along the view).
    """
    from scipy.spatial.transform import Rotation, Slerp  # here: only exports need it

    if not traj.frames:
        raise SettingsError("the motion has no frames: nothing to export")
    timing = traj.timing
    w, h = traj.size
    if timing.direction in ("left-right", "right-left"):  # top-bottom orientation
        w, h = h, w
    size, period = (h, w), 1.0 / fps
    cam = Lens(lens.focal, lens.k)
    rows = np.linspace(0, h - 1, _ROWS)
    t0 = traj.frames[0].start
    starts = np.array([fm.start - t0 for fm in traj.frames])
    row_t = (starts[:, None] + timing.readout * rows[None] / h) * period  # (n, rows)
    ref_t = np.array([timing.reference_time(h, s) for s in starts]) * period
    def at_rows(values: np.ndarray) -> np.ndarray:
        return np.stack([np.interp(rows, np.arange(h), values[:, i]) for i in range(2)], -1)

    disp = np.array([at_rows(fm.camera_displacement) for fm in traj.frames])  # (n, rows, 2)
    vel = np.array([at_rows(fm.velocity) for fm in traj.frames]) / period  # px/s
    roll_ref = np.array([fm.reframe.path[2] for fm in traj.frames])

    # The camera path between reference times: its velocity, integrated in time order.
    flat_t, order = row_t.ravel(), np.argsort(row_t.ravel(), kind="stable")
    flat_v = vel.reshape(-1, 2)[order]
    path = np.concatenate([np.zeros((1, 2)), np.cumsum(
        0.5 * (flat_v[1:] + flat_v[:-1]) * np.diff(flat_t[order])[:, None], axis=0)])
    c_ref = np.stack([np.interp(ref_t, flat_t[order], path[:, i]) for i in range(2)], -1)
    step = np.diff(c_ref, axis=0)
    turn = np.stack([-step[:, 1] / lens.focal, step[:, 0] / lens.focal,
                     np.diff(roll_ref)], axis=1)
    c_frames = [Rotation.identity()]
    for v in turn:
        c_frames.append(Rotation.from_rotvec(v) * c_frames[-1])

    # Within each frame: the rotation of every row to its reference (module notes).
    cx = (w - 1) / 2.0
    src = np.stack([np.full(rows.size, cx), rows], axis=1)
    times, keys = [], []
    for n in range(len(traj.frames)):
        roll = roll_ref[n] - np.interp(row_t[n], ref_t, roll_ref)
        phi = _row_turns(src, src - disp[n], roll, cam, size)
        times.append(row_t[n])
        keys.append(Rotation.from_rotvec(phi).inv() * c_frames[n])
    key_t = np.concatenate(times)
    key_r = Rotation.concatenate(keys)
    keep = np.concatenate([[True], np.diff(key_t) > 1e-9])  # overlapping frames: first
    keep &= np.maximum.accumulate(key_t) <= key_t
    key_t, key_r = key_t[keep], key_r[keep]
    per_frame = max(SAMPLES_PER_READOUT, math.ceil(SAMPLES_PER_READOUT / timing.readout))
    dt = period / per_frame
    # A step past the end of the last frame's interval, as a gyro's log would run on.
    t = np.arange(0.0, max(key_t[-1], (starts[-1] + 1.0) * period) + 1.5 * dt, dt)
    if key_t.size < 2:
        return t, np.zeros((t.size, 3))
    orient = Slerp(key_t, key_r)(np.clip(t, key_t[0], key_t[-1]))
    rate = np.zeros((t.size, 3))
    if t.size > 1:
        rate[1:] = (orient[1:] * orient[:-1].inv()).as_rotvec() / dt
    return t, rate @ coded_axes(timing.direction).T


def log_rates(time: np.ndarray, rate: np.ndarray, axes: np.ndarray, offset: float,
              span: float, direction: str) -> tuple[np.ndarray, np.ndarray]:
    """Return a calibrated gyro log as it was used: camera axes, the clip's clock, from time 0.

    Parameters
    ----------
    time, rate : ndarray
        The log (seconds, rad/s about the gyro's axes).
    axes : ndarray of shape (3, 3)
        Camera-from-gyro mapping (top-bottom orientation) the calibration found.
    offset : float
        Log time of the first frame's first scanline.
    span : float
        Seconds from there to the last frame's last scanline.
    direction : str
        Scan direction (the rates are written about the coded frame's axes).
    """
    rel = time - offset
    cam = rate @ axes.T @ coded_axes(direction).T
    inside = (rel > 0) & (rel <= span + 0.1)
    first = np.array([[np.interp(0.0, rel, cam[:, i]) for i in range(3)]])
    return (np.concatenate([[0.0], rel[inside]]),
            np.concatenate([first, cam[inside]], axis=0))


def gcsv_text(time: np.ndarray, rate: np.ndarray, *, readout_ms: float, direction: str,
              lens: ProjectLens, video: str, note: str, start: float = 0.0,
              steps: bool = True) -> str:
    """Return a ``.gcsv`` log (Gyroflow's format) of rates about the coded frame's camera axes.

    The header puts ``frame_readout_time`` and ``frame_readout_direction`` within the first
    500 bytes, where telemetry-parser looks for them; ``tscale`` 0.001 (times in ms),
    ``gscale`` 1 (rad/s). ``vendor`` ``unjello`` says that the columns are the camera's
    axes, ``unjello_focal`` (px) the lens the rates were taken through and
    ``unjello_start`` the clip's time (s) of time 0, its first frame's first scanline
    (:func:`unjello.io.gcsv.stated_calibration`); ``unjello_rates`` ``steps`` that each
    rate is the mean over the step before its time (:func:`camera_rates`), ``samples``
    that they are a gyro's own samples (:func:`log_rates`).
    """
    lines = ["GYROFLOW IMU LOG", "version,1.3", "id,unjello", f"orientation,{ORIENTATION}",
             f"frame_readout_time,{readout_ms:.4f}",
             f"frame_readout_direction,{_DIRECTION_CODES[direction]}",
             "vendor,unjello", f"fwversion,{__version__}", f"unjello_focal,{lens.focal:.4f}",
             f"unjello_start,{start:.6f}", f"unjello_rates,{'steps' if steps else 'samples'}",
             f"videofilename,{Path(video).name}", f"note,{note.replace(',', ';')}",
             "tscale,0.001", "gscale,1", "t,gx,gy,gz"]
    body = np.column_stack([time * 1000.0, rate])
    rows = "\n".join(f"{r[0]:.4f},{r[1]:.7g},{r[2]:.7g},{r[3]:.7g}" for r in body)
    return "\n".join(lines) + "\n" + rows + "\n"


def project(*, video: str, gcsv: str, width: int, height: int, fps: float, frames: int,
            rotation: float, timing: SensorTiming, lens: ProjectLens, start: float = 0.0
            ) -> dict:
    """Return a ``.gyroflow`` project (version 4) that corrects rolling shutter only.

    ``stabilization.method`` ``No smoothing``, no zoom (``adaptive_zoom_window`` 0, ``fov``
    1), the gyro from ``gcsv`` integrated as it is (``integration_method`` 3: the gyro
    alone, no accelerometer to fuse), the lens as ``calibration_data`` (OpenCV's standard
    model with no distortion for a rectilinear lens, its fisheye model otherwise), and
    ``offsets`` of minus half a readout (module notes) plus ``start``, the clip's time (s)
    of the gcsv's time 0.
    """
    readout_ms = timing.readout * 1000.0 / fps
    fisheye = lens.k is not None
    dims = {"w": int(width), "h": int(height)}
    calibration = {
        "name": f"unjello {lens.describe()}", "note": f"written by unjello {__version__}",
        "calibrated_by": "unjello", "camera_brand": "", "camera_model": "",
        "lens_model": "", "camera_setting": "", "calib_dimension": dims,
        "orig_dimension": dims, "frame_readout_time": readout_ms, "fps": fps,
        "distortion_model": "opencv_fisheye" if fisheye else "opencv_standard",
        "fisheye_params": {
            "RMS_error": 0.0,
            "camera_matrix": [[lens.focal, 0.0, width / 2], [0.0, lens.focal, height / 2],
                              [0.0, 0.0, 1.0]],
            "distortion_coeffs": [float(v) for v in lens.k or ()] if fisheye else [0.0] * 5}}
    return {
        "title": "Gyroflow data file", "version": 4,
        "app_version": f"unjello {__version__}", "videofile": video,
        "calibration_data": calibration,
        "video_info": {"width": int(width), "height": int(height), "rotation": rotation,
                       "num_frames": int(frames), "fps": fps,
                       "duration_ms": frames * 1000.0 / fps, "fps_scale": None,
                       "vfr_fps": fps, "vfr_duration_ms": frames * 1000.0 / fps},
        "stabilization": {
            "fov": 1.0, "method": "No smoothing", "smoothing_params": [],
            "frame_readout_time": readout_ms,
            "frame_readout_direction": _DIRECTION_CODES[timing.direction],
            "adaptive_zoom_window": 0.0, "lens_correction_amount": 0.0 if fisheye else 1.0,
            "horizon_lock_amount": 0.0, "horizon_lock_roll": 0.0,
            "additional_rotation": [0.0, 0.0, 0.0]},
        "gyro_source": {"filepath": gcsv, "imu_orientation": ORIENTATION,
                        "rotation": [0.0, 0.0, 0.0], "integration_method": 3,
                        "lpf": 0.0, "mf": 0},
        "offsets": {"0": 1000.0 * start - readout_ms / 2},
    }


def gcsv_path(project_path: str | os.PathLike) -> Path:
    """Return the gcsv written beside a project: the same name, ``.gcsv``."""
    return Path(project_path).with_suffix(".gcsv")


def write_gyroflow(project_path: str | os.PathLike, *, time: np.ndarray, rate: np.ndarray,
                   video: str | os.PathLike, width: int, height: int, fps: float,
                   frames: int, rotation: float, timing: SensorTiming, lens: ProjectLens,
                   note: str, start: float = 0.0, steps: bool = True,
                   overwrite: bool = False) -> tuple[Path, Path]:
    """Write ``NAME.gcsv`` and ``NAME.gyroflow`` beside each other, atomically.

    Both are checked before either is written (nothing replaced without ``overwrite``);
    each appears only when complete. ``steps``: the rates are :func:`camera_rates`'s (each
    the mean over the step before its time), not a gyro's samples. Returns their paths
    (gcsv, project).
    """
    dst = Path(project_path)
    if dst.suffix.lower() != ".gyroflow":
        raise SettingsError(f"{dst.name}: a Gyroflow project's name ends .gyroflow "
                            "(the plugins look for CLIP.gyroflow beside the clip)")
    log_path = gcsv_path(dst)
    for p in (dst, log_path):
        check_new(p, overwrite)
    video_abs = os.path.abspath(video)
    text = gcsv_text(time, rate, readout_ms=timing.readout * 1000.0 / fps,
                     direction=timing.direction, lens=lens, video=video_abs, note=note,
                     start=start, steps=steps)
    doc = project(video=video_abs, gcsv=os.path.abspath(log_path), width=width,
                  height=height, fps=fps, frames=frames, rotation=rotation, timing=timing,
                  lens=lens, start=start)
    written: list[Path] = []
    try:
        for path, content in ((log_path, text), (dst, json.dumps(doc, indent=2))):
            tmp = temp_path(path)
            written.append(tmp)
            try:
                tmp.write_text(content, encoding="utf-8")
            except OSError as exc:
                raise cannot_write(path, exc) from None
        for tmp, path in zip(written, (log_path, dst), strict=True):
            replace(tmp, path)
    finally:
        for tmp in written:
            remove(tmp)
    return log_path, dst


def gyroflow_displacement(time_ms: np.ndarray, imu: np.ndarray, *, offset_ms: float,
                          fps: float, readout_ms: float, size: tuple[int, int],
                          focal: float, frames: np.ndarray) -> np.ndarray:
    """Return what Gyroflow's rule does with a log, per row: the check of :func:`camera_rates`.

    A re-implementation, from Gyroflow's source, of what it applies under ``No smoothing``
    to a rectilinear, top-to-bottom clip (module notes), for the centre column:
    its IMU axes ``g`` integrated as ``O_k = O_{k-1} exp((-g_y, g_x, g_z) dt)``
    (``SimpleGyroIntegrator``), frame ``n`` at video time ``n T`` (its middle row), row
    ``y`` at ``n T - R / 2 + R y / h`` (``R`` the readout), looked up at that time less
    the offset, ``r_y = F Q(O(t_n)^-1 O(t_y)) F`` with ``F = diag(-1, 1, 1)``, and the
    source of output pixel ``o`` at ``K r_y^-1 K^-1 o``.

    Parameters
    ----------
    time_ms : ndarray of shape (n,)
        Sample times, ms from the first (telemetry-parser's ``timestamp_ms``).
    imu : ndarray of shape (n, 3)
        Rates in Gyroflow's IMU axes (the gcsv's columns through its ``orientation``),
        degrees per second, as telemetry-parser's ``normalized_imu`` gives them.
    offset_ms : float
        The project's offset (gyro time = video time - offset).
    fps, readout_ms : float
        Frame rate; readout time in ms.
    size : (int, int)
        Frame height and width.
    focal : float
        Focal length, pixels.
    frames : ndarray of int
        The frames to return.

    Returns
    -------
    ndarray of shape (len(frames), h, 2)
        Per row, ``s - p`` at the centre column: ``p`` the output pixel whose source is
        the row's centre pixel ``s`` (eq. 26's per-scanline displacement).
    """
    from scipy.spatial.transform import Rotation, Slerp  # here: only exports need it

    h, w = size
    g = np.deg2rad(np.asarray(imu, np.float64))
    body = np.stack([-g[:, 1], g[:, 0], g[:, 2]], axis=1)
    t = np.asarray(time_ms, np.float64)
    dt = np.diff(t, prepend=t[0] - (t[-1] - t[0]) / max(t.size - 1, 1)) / 1000.0
    steps = Rotation.from_rotvec(body * dt[:, None])
    orient = [Rotation.identity()]
    for k in range(t.size):
        orient.append(orient[-1] * steps[k])
    path = Slerp(t, Rotation.concatenate(orient[1:]))
    flip = np.diag([-1.0, 1.0, 1.0])
    k_mat = np.array([[focal, 0, w / 2], [0, focal, h / 2], [0, 0, 1.0]])
    ys = np.arange(h, dtype=np.float64)
    s = np.stack([np.full(h, w / 2), ys, np.ones(h)], axis=1)
    out = np.empty((len(frames), h, 2))
    for i, n in enumerate(frames):
        ts = n * 1000.0 / fps
        row_t = ts - readout_ms / 2 + readout_ms / h * ys
        at = path(np.clip(np.concatenate([[ts], row_t]) - offset_ms, t[0], t[-1]))
        q = (at[0].inv() * at[1:]).as_matrix()  # (h, 3, 3)
        r = flip @ q @ flip
        p = np.einsum("ij,njk,kl,nl->ni", k_mat, r, np.linalg.inv(k_mat), s)
        out[i] = s[:, :2] - p[:, :2] / p[:, 2:3]
    return out


def export_project(traj: Trajectory, project_path: str | os.PathLike, *,
                   video: str | os.PathLike, fps: float, lens: ProjectLens, frames: int,
                   rotation: float = 0.0, gyro: tuple | None = None,
                   overwrite: bool = False) -> tuple[tuple[Path, Path], str]:
    """Write a clip's motion as ``NAME.gcsv`` and ``NAME.gyroflow`` (module notes).

    Parameters
    ----------
    traj : Trajectory
        The motion unjello measured (or applied) on ``video``.
    project_path : path-like
        The project, ``NAME.gyroflow``; the log goes beside it as ``NAME.gcsv``.
    video : path-like
        The clip the project corrects (the original, not unjello's output).
    fps : float
        Its frame rate.
    lens : ProjectLens
        The lens (with the gyro method, its calibration's).
    frames : int
        Its number of frames.
    rotation : float
        Its display rotation, degrees.
    gyro : (GyroLog, GyroCalibration), optional
        With the gyro method: the log and its calibration, written as they were used
        (:func:`log_rates`) instead of the rates of the per-row motion.
    overwrite : bool
        Replace existing files.

    Returns
    -------
    paths : (Path, Path)
        The gcsv and the project.
    said : str
        One line: what was written, from what, through which lens.
    """
    timing = traj.timing
    start = traj.frames[0].start / fps if traj.frames else 0.0
    if gyro is not None:
        log, cal = gyro
        span = (traj.frames[-1].start - traj.frames[0].start + timing.readout) / fps
        time, rate = log_rates(log.time, log.rate, cal.axes,
                               cal.offset + start, span, timing.direction)
        what = "the calibrated gyro as it was used"
    else:
        time, rate = camera_rates(traj, lens, fps)
        what = f"rates of the {traj.method or 'measured'} method's per-scanline camera motion"
    w, h = traj.size
    paths = write_gyroflow(project_path, time=time, rate=rate, video=video, width=w,
                           height=h, fps=fps, frames=frames, rotation=rotation,
                           timing=timing, lens=lens, note=f"unjello: {what}", start=start,
                           steps=gyro is None, overwrite=overwrite)
    said = f"wrote {paths[1]} and {paths[0].name} ({what}; lens {lens.describe()})"
    if lens.guessed:
        said = ("warning: no lens is known for this clip, so the project's field of view is "
                f"guessed ({GUESSED_FOV:.0f} degrees across the width): give --focal or "
                "--lens-profile for rotations of the right size; " + said)
    return paths, said


def check_project(project_path: str | os.PathLike, pipe: bool, whole: bool,
                  overwrite: bool) -> None:
    """Refuse a project that cannot be written, before the clip is corrected.

    Raises
    ------
    SettingsError
        From standard input (a project names its clip) or for a part of the clip.
    OutputError
        Its files exist (without ``overwrite``) or their folder is missing.
    """
    if pipe:
        raise SettingsError("a Gyroflow project names its clip: give a file, not standard "
                            "input")
    if not whole:
        raise SettingsError("a Gyroflow project corrects the whole clip: leave out start= "
                            "and duration=")
    for path in (project_path, gcsv_path(project_path)):
        check_new(path, overwrite)


def project_lens(config: CorrectionConfig, camera: str | None, size: tuple[int, int],
                 fps: float) -> ProjectLens:
    """Return the lens a Gyroflow project is written with.

    What is given (``focal``, ``distortion``), else a lens profile's, else the camera
    database's for ``camera`` (:func:`unjello.clip.with_lens`); a lens no one states is
    guessed (:meth:`ProjectLens.guess`).
    """
    given = config.gyro.focal is not None
    config, said = with_lens(config, camera, size, fps)
    g = config.gyro
    if g.focal is None:
        return ProjectLens.guess(size[0])
    source = "given" if given else said[0].split(":")[0].removeprefix("lens from the ")
    return ProjectLens(g.focal, g.distortion, source)


def clip_project(traj: Trajectory, project_path: str | os.PathLike, *, clip: Path,
                 config: CorrectionConfig, fps: float, rotation: float,
                 gyro: GyroOrDense | None, overwrite: bool,
                 log: Callable[[str], None] | None = None) -> None:
    """Write a corrected clip's Gyroflow project (``correct_video(gyroflow_out=)``).

    The gyro method's calibrated log and lens when it was used (:func:`log_rates`), else
    the rates of the motion (:func:`camera_rates`) through :func:`project_lens`.
    """
    cal = gyro.gyro.calibration if gyro is not None and gyro.method == "gyro" else None
    if gyro is not None and cal is not None:
        lens = ProjectLens(cal.focal, cal.distortion, "the gyro's calibration")
        used: tuple | None = (gyro.gyro.log, cal)
    else:
        camera = config.camera or (camera_of(clip) if clip.is_file() else None)
        lens = project_lens(config, camera, traj.size, fps)
        used = None
    _, said = export_project(traj, project_path, video=clip, fps=fps, lens=lens,
                             frames=len(traj), rotation=rotation, gyro=used,
                             overwrite=overwrite)
    if log:
        log(said)
