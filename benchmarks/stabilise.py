"""Stabilisation: `unjello correct --stabilize` side by side with vid.stab (ffmpeg).

vid.stab (``vidstabdetect`` + ``vidstabtransform``, inside ffmpeg) is the open-source
stabiliser most people have; it has no rolling-shutter correction. Both tools read the
same PNG frames and write PNG frames (no codec in between); the measurements read the
outputs only, the same way for both.

1. Simulated hand-held clips (shake, a walk, a pan with shake; 640x360, readout 0.8,
   90 frames at 30 fps), whose intended (smooth) camera path the simulator knows. Both
   tools crop the same 10 % (unjello ``--crop 0.1``, vid.stab ``zoom=11.11:optzoom=0``).
   The output's inter-frame motion is measured (features tracked in the central 70 %,
   a similarity fitted with RANSAC); the *residual jitter* is the output's camera path
   (the measured motion less the intended one, accumulated) less its 1 s low-pass, RMS
   in px. The rolling-shutter error: PSNR of unjello's output against the global-
   shutter truth shown through the same reframe (its motion JSON), central 80 %, with
   and without ``--stabilize``.
2. Real clips (``../shared/data/sequences``: the phone in a car, the two GoPro files;
   the first ``--frames`` frames): the high-frequency energy of the output's global
   inter-frame motion's path (the path less its Gaussian low-pass of 1 s, i.e. above
   about 0.15 Hz; x, y and the rotation as px at the frame's corner: each as an RMS,
   and their squares summed as the energy; averaged over six constant sub-pixel shifts
   of the clip, which change none of its motion, with the energy's spread), for the
   input, vid.stab (its defaults, with its own static zoom) and unjello
   (``--stabilize``, automatic crop). The phone clip again with its gyro log
   (``--method gyro``): the path from the gyro's rotation instead of tracked points.
3. Speed: ``unjello correct`` with and without ``--stabilize`` on a 1080p clip of 150
   frames, two alternating rounds in one run (``--speed``).

Usage::

    python benchmarks/stabilise.py [--frames 150] [--speed] [--skip-real]

vid.stab needs an ffmpeg built with it (Debian's and most distributions' are); without
it those columns are skipped, with the reason.
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
from scipy.ndimage import gaussian_filter1d
from skimage import data

from unjello.simulate import Motion, simulate
from unjello.timing import SensorTiming, pixel_grid
from unjello.trajectory import Trajectory
from unjello.warp.maps import reframe_maps
from unjello.warp.warper import apply_maps

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
UNJELLO = [sys.executable, "-m", "unjello"]
FPS = 30.0
CROP = 0.1


def _frames(folder: Path) -> list[np.ndarray]:
    def key(p: Path) -> list:
        return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", p.name)]
    return [cv2.imread(str(p)) for p in sorted(folder.glob("*.png"), key=key)]


def _write(frames: list[np.ndarray], folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for i, f in enumerate(frames):
        cv2.imwrite(str(folder / f"{i:05d}.png"), f)
    return folder


def vidstab_missing() -> str | None:
    """None when ffmpeg with vid.stab runs here, else why not."""
    if shutil.which("ffmpeg") is None:
        return "no ffmpeg on this machine (Debian: apt install ffmpeg)"
    out = subprocess.run(["ffmpeg", "-hide_banner", "-filters"], capture_output=True,
                         text=True).stdout
    return None if "vidstabtransform" in out else "this ffmpeg is built without vid.stab"


def run_vidstab(src: Path, dst: Path, *, smoothing: int = 10, zoom: float | None = None,
                shakiness: int = 5) -> float:
    """vid.stab's two passes on a PNG folder (it reads planar YUV); returns seconds."""
    dst.mkdir(parents=True, exist_ok=True)
    trf = dst / "transforms.trf"
    pattern = ["-framerate", str(FPS), "-i", str(src / "%05d.png")]
    t0 = time.perf_counter()
    subprocess.run(["ffmpeg", "-v", "error", "-y", *pattern, "-vf",
                    f"format=yuv420p,vidstabdetect=shakiness={shakiness}:accuracy=15:result={trf}",
                    "-f", "null", "-"],
                   check=True)
    zoom_opt = f":zoom={zoom:.2f}:optzoom=0" if zoom is not None else ""
    subprocess.run(["ffmpeg", "-v", "error", "-y", *pattern, "-vf",
                    f"format=yuv420p,vidstabtransform=input={trf}:smoothing={smoothing}{zoom_opt}"
                    ":interpol=bicubic", "-start_number", "0", str(dst / "%05d.png")],
                   check=True)
    return time.perf_counter() - t0


def run_unjello(src: Path, dst: Path, *extra: str) -> float:
    t0 = time.perf_counter()
    subprocess.run([*UNJELLO, "correct", str(src), "-o", str(dst), "--fps", str(FPS), "-y",
                    "--motion-out", str(dst.with_suffix(".json")), *extra],
                   check=True, capture_output=True)
    return time.perf_counter() - t0


def interframe_motion(frames: list[np.ndarray]) -> np.ndarray:
    """Per consecutive pair: the content's shift (x, y, px) and rotation (rad), (n-1, 3).

    Features in the central 70 % of the earlier frame, tracked by pyramidal Lucas-Kanade,
    a similarity fitted with RANSAC (as stabilisers measure motion).
    """
    out = []
    for a, b in zip(frames[:-1], frames[1:], strict=True):
        ga, gb = (cv2.cvtColor(f, cv2.COLOR_BGR2GRAY) for f in (a, b))
        h, w = ga.shape
        mask = np.zeros_like(ga)
        mask[int(0.15 * h):int(0.85 * h), int(0.15 * w):int(0.85 * w)] = 255
        pts = cv2.goodFeaturesToTrack(ga, 400, 0.01, 8, mask=mask)
        if pts is None or len(pts) < 8:
            out.append((np.nan, np.nan, np.nan))
            continue
        nxt, st, _ = cv2.calcOpticalFlowPyrLK(ga, gb, pts, None, winSize=(21, 21), maxLevel=4)
        ok = st.ravel() == 1
        m, _ = cv2.estimateAffinePartial2D(pts[ok], nxt[ok], method=cv2.RANSAC,
                                           ransacReprojThreshold=1.0)
        if m is None:
            out.append((np.nan, np.nan, np.nan))
            continue
        # Shift of the frame's centre, and the rotation.
        c = np.array([(w - 1) / 2, (h - 1) / 2])
        moved = m[:, :2] @ c + m[:, 2]
        out.append((*(moved - c), np.arctan2(m[1, 0], m[0, 0])))
    arr = np.array(out, dtype=np.float64)
    bad = ~np.isfinite(arr).all(axis=1)
    if bad.any() and (~bad).any():  # bridge a failed pair with its neighbours
        for k in range(3):
            arr[bad, k] = np.interp(np.flatnonzero(bad), np.flatnonzero(~bad), arr[~bad, k])
    return arr


def high_pass(path: np.ndarray, seconds: float = 1.0) -> np.ndarray:
    """Return a path less its Gaussian low-pass of ``seconds`` (standard deviation).

    Beyond its ends the path is continued point-symmetrically (``2 p[0] - p[k]``), so a
    steady drift has no high-frequency part. (Continuing it flat, ``mode='nearest'``, as
    this benchmark first did, bends a drift at each end: the GoPro Max's 0.5 px a frame
    walk read as 4.5 px of "high-frequency motion" that no stabiliser could remove.)
    """
    sigma = seconds * FPS
    pad = min(len(path) - 1, int(4 * sigma))
    ext = np.concatenate([2 * path[:1] - path[pad:0:-1], path,
                          2 * path[-1:] - path[-2:-pad - 2:-1]])
    low = gaussian_filter1d(ext, sigma, axis=0, mode="nearest")[pad:pad + len(path)]
    return path - low


# ---------------------------------------------------------------- simulated clips

def handheld(kind: str, frames: int = 150) -> tuple[Motion, Motion]:
    """Return the actual motion and its intended smooth part, of a hand-held clip."""
    t = np.arange(-2.0, frames + 10.0, 0.25)
    sec = t / FPS
    shake = Motion("shake")(t)
    if kind == "shake":
        smooth = np.zeros((t.size, 2))
        actual = shake
    elif kind == "walk":  # 2 px/frame forward drift, a 2 Hz bob and a 1 Hz sway
        smooth = np.stack([2.0 * t, np.zeros_like(t)], axis=1)
        bob = np.stack([3.0 * np.sin(2 * np.pi * 1.0 * sec), 5.0 * np.abs(
            np.sin(2 * np.pi * 1.0 * sec)) - 3.2], axis=1)
        actual = smooth + bob + 0.5 * shake
    elif kind == "pan + shake":
        smooth = np.stack([5.0 * t, 1.0 * t], axis=1)
        actual = smooth + shake
    else:
        raise ValueError(kind)
    spline = Motion("spline", knots=(tuple(t), tuple(actual[:, 0]), tuple(actual[:, 1])))
    ideal = Motion("spline", knots=(tuple(t), tuple(smooth[:, 0]), tuple(smooth[:, 1])))
    return spline, ideal


def _psnr(a: np.ndarray, b: np.ndarray) -> float:
    h, w = a.shape[:2]
    sl = (slice(int(0.1 * h), int(0.9 * h)), slice(int(0.1 * w), int(0.9 * w)))
    err = np.mean((a[sl].astype(np.float64) - b[sl].astype(np.float64)) ** 2)
    return float(10 * np.log10(255.0 ** 2 / max(err, 1e-12)))


def rs_psnr(outputs: list[np.ndarray], truths: list[np.ndarray], motion_json: Path) -> float:
    """Mean PSNR against the truth shown through each frame's reframe (central 80 %)."""
    traj = Trajectory.load(motion_json)
    vals = []
    for out, truth, fm in zip(outputs, truths, traj.frames, strict=True):
        h, w = truth.shape[:2]
        grid = pixel_grid(h, w)
        expected = apply_maps(truth, reframe_maps(grid, fm.reframe, (h, w)))
        vals.append(_psnr(out, expected))
    return float(np.mean(vals))


def simulated(work: Path, missing: str | None, frames: int) -> None:
    print(f"1. simulated hand-held clips: 640x360, readout 0.8, {frames} frames, crop "
          f"{CROP:.0%} for both; residual jitter (px RMS, high-passed at 1 s) and "
          "frame-to-frame error (px RMS)")
    head = f"{'clip':14}{'input':>16}{'vid.stab s=10':>16}{'vid.stab s=27':>16}{'unjello':>16}"
    print(head + "   RS PSNR (dB): corrected / corrected+stabilised")
    timing = SensorTiming(0.8)
    scene = data.astronaut()
    zoom = 1.0 / (1.0 - CROP)
    for kind in ("shake", "walk", "pan + shake"):
        actual, ideal = handheld(kind)
        sims = list(simulate(scene, actual, timing, frames, size=(640, 360)))
        bgr = [cv2.cvtColor(s.rolling, cv2.COLOR_RGB2BGR) for s in sims]
        truth = [cv2.cvtColor(s.truth, cv2.COLOR_RGB2BGR) for s in sims]
        src = _write(bgr, work / kind.replace(" ", "_") / "in")
        # The intended inter-frame motion of the content at the frames' reference times.
        tref = np.array([timing.reference_time(360, s.motion.start) for s in sims])
        ideal_steps = np.diff(ideal(tref), axis=0)

        def jitter(outs: list[np.ndarray], scale: float,
                   ideal_steps: np.ndarray = ideal_steps) -> tuple[float, float]:
            steps = interframe_motion(outs)[:, :2]
            resid = steps - scale * ideal_steps
            path = np.cumsum(resid, axis=0)
            return (float(np.sqrt((high_pass(path) ** 2).sum(axis=1).mean())),
                    float(np.sqrt((resid ** 2).sum(axis=1).mean())))

        cells = [jitter(bgr, 1.0)]
        for smoothing in (10, 27):
            if missing is not None:
                cells.append((np.nan, np.nan))
                continue
            dst = work / kind.replace(" ", "_") / f"vidstab{smoothing}"
            run_vidstab(src, dst, smoothing=smoothing, zoom=100 * (zoom - 1))
            cells.append(jitter(_frames(dst), zoom))
        plain = work / kind.replace(" ", "_") / "plain"
        run_unjello(src, plain, "--readout", "0.8")
        stab = work / kind.replace(" ", "_") / "stab"
        run_unjello(src, stab, "--readout", "0.8", "--stabilize", "--crop", str(CROP))
        out = _frames(stab)
        cells.append(jitter(out, zoom))
        rs = (rs_psnr(_frames(plain), truth, plain.with_suffix(".json")),
              rs_psnr(out, truth, stab.with_suffix(".json")))
        print(f"{kind:14}" + "".join(f"{a:9.2f} / {b:4.2f}" if np.isfinite(a) else
                                     f"{'skipped':>16}" for a, b in cells)
              + f"   {rs[0]:.2f} / {rs[1]:.2f}", flush=True)
    if missing is None:
        print("   (vid.stab s=N: smoothing=N, a window of 2N+1 frames; 27 is unjello's "
              "window at --smoothness 0.3)")
    else:
        print(f"   vid.stab skipped: {missing}")


def phase_jitter(frames: list[np.ndarray]) -> float:
    """RMS of the frame-to-frame change of the global translation, px per frame squared.

    The translation between consecutive frames by phase correlation (Hann window) on
    their central 60 %: a stabiliser's output should move steadily, so what changes from
    one step to the next is jitter. (Issue 31's measure.)
    """
    steps = []
    for a, b in zip(frames[:-1], frames[1:], strict=True):
        ga, gb = (cv2.cvtColor(f, cv2.COLOR_BGR2GRAY).astype(np.float32) for f in (a, b))
        h, w = ga.shape
        sl = (slice(int(0.2 * h), int(0.8 * h)), slice(int(0.2 * w), int(0.8 * w)))
        win = cv2.createHanningWindow((ga[sl].shape[1], ga[sl].shape[0]), cv2.CV_32F)
        steps.append(cv2.phaseCorrelate(ga[sl].copy(), gb[sl].copy(), win)[0])
    change = np.diff(np.array(steps), axis=0)
    return float(np.sqrt((change ** 2).sum(axis=1).mean()))


def walk(work: Path, missing: str | None, frames: int) -> None:
    """Print the walk's jitter: shake (3.6 x 'shake') on a 2 px/frame pan, each tool's crop."""
    print(f"\n1b. a walk (simulated: Motion('walk'), shake on a 2 px/frame pan), 640x360, "
          f"readout 0.8, {frames} frames; jitter (phase correlation, central 60 %: RMS of "
          "the frame-to-frame change of the translation, px/frame^2), each tool's own crop")
    timing = SensorTiming(0.8)
    sims = list(simulate(data.astronaut(), Motion("walk", speed=2.0), timing, frames,
                         size=(640, 360)))
    bgr = [cv2.cvtColor(s.rolling, cv2.COLOR_RGB2BGR) for s in sims]
    truth = [cv2.cvtColor(s.truth, cv2.COLOR_RGB2BGR) for s in sims]
    src = _write(bgr, work / "walk" / "in")
    cells = {"input": phase_jitter(bgr)}
    if missing is None:
        for label, kw in (("vid.stab defaults", {}),
                          ("vid.stab shakiness=8, smoothing=15",
                           {"smoothing": 15, "shakiness": 8})):
            dst = work / "walk" / label.split(",")[0].replace(" ", "_").replace("=", "")
            run_vidstab(src, dst, **kw)
            cells[label] = phase_jitter(_frames(dst))
    plain, stab = work / "walk" / "plain", work / "walk" / "stab"
    run_unjello(src, plain, "--readout", "0.8")
    run_unjello(src, stab, "--readout", "0.8", "--stabilize")
    out = _frames(stab)
    cells["unjello --stabilize"] = phase_jitter(out)
    zooms = [f.reframe.zoom for f in Trajectory.load(stab.with_suffix(".json")).frames]
    print("   " + "; ".join(f"{k} {v:.2f}" for k, v in cells.items())
          + f" (unjello's zoom {min(zooms):.3f}-{max(zooms):.3f})")
    rs = (rs_psnr(_frames(plain), truth, plain.with_suffix(".json")),
          rs_psnr(out, truth, stab.with_suffix(".json")))
    print(f"   RS PSNR (dB): corrected {rs[0]:.2f} / corrected+stabilised {rs[1]:.2f}")
    if missing is not None:
        print(f"   vid.stab skipped: {missing}")


# ---------------------------------------------------------------- real clips

def _read_video(path: Path, limit: int) -> list[np.ndarray]:
    cap = cv2.VideoCapture(str(path))
    out = []
    while len(out) < limit:
        ok, f = cap.read()
        if not ok:
            break
        out.append(f)
    return out


#: Constant sub-pixel shifts of a whole clip: they change none of its motion, yet on
#: the phone in a car (moving traffic, a RANSAC fit that may pick either layer) one
#: alone moved the figure by -7 % to +4 % (0.25 px: 128.17 -> 119.53 px^2; JPEG at
#: quality 95: 132.78), so each clip is measured under all of them and averaged.
NULL_SHIFTS = ((0.0, 0.0), (0.25, 0.25), (0.5, 0.0), (0.0, 0.5), (0.5, 0.5), (0.75, 0.25))


def hf_energy(frames: list[np.ndarray]) -> tuple[float, float, float]:
    """Return the high-frequency RMS of the inter-frame motion: translation, rotation.

    The rotation is given as px at the frame's corner. Averaged over the clip shifted
    by each of :data:`NULL_SHIFTS`; the third value is the spread (standard deviation)
    of the energy (translation^2 + rotation^2) over them.
    """
    h, w = frames[0].shape[:2]
    corner = 0.5 * np.hypot(w, h)
    rows = []
    for dx, dy in NULL_SHIFTS:
        shifted = frames if dx == dy == 0 else [
            cv2.warpAffine(f, np.float32([[1, 0, dx], [0, 1, dy]]), (w, h),
                           flags=cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT)
            for f in frames]
        hp = high_pass(np.cumsum(interframe_motion(shifted), axis=0))
        rows.append(((hp[:, :2] ** 2).sum(axis=1).mean(), (hp[:, 2] ** 2).mean() * corner ** 2))
    sq = np.array(rows)
    return (float(np.sqrt(sq[:, 0].mean())), float(np.sqrt(sq[:, 1].mean())),
            float(sq.sum(axis=1).std()))


def real(work: Path, missing: str | None, frames: int, only: str = "") -> None:
    print(f"\n2. real clips, first {frames} frames: high-frequency motion of the output "
          "(px RMS above ~0.15 Hz: translation / rotation at the corner); lower is steadier")
    print(f"{'clip':26}{'input':>16}{'vid.stab':>16}{'unjello':>16}   unjello's zoom   "
          "energy (px^2: input / vid.stab / unjello)")
    phone = SHARED / "sequences" / "phone_gyro"
    clips = {"phone in a car (reshape)": (phone / "reshape", []),
             "phone, its gyro's path": (phone / "reshape",
                                        ["--method", "gyro", "--gyro", str(phone / "gyro.txt")]),
             "GoPro HERO5 on a Karma": (SHARED / "sequences" / "gopro_gpmf" / "karma.mp4", []),
             "GoPro Max, hero mode": (SHARED / "sequences" / "gopro_gpmf" / "max-heromode.mp4",
                                      [])}
    done: dict[Path, tuple[Path, list]] = {}
    for name, (path, method) in clips.items():
        if only and only not in name:
            continue
        if not path.exists():
            print(f"{name:26} skipped: {path} is absent")
            continue
        if path.is_dir():
            def key(p: Path) -> list:
                return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", p.name)]
            files = sorted(path.glob("*.jpg"), key=key)[:frames]
            imgs = [cv2.imread(str(p)) for p in files]
            extra = ["--readout", "1.0"]  # its publisher: a 33.3 ms span at 30 fps
        else:
            imgs = _read_video(path, frames)
            extra = []
        tag = name.split(",")[0].split()[0].lower()
        src = _write(imgs, work / tag / "in") if path not in done else done[path][0]
        cells = [hf_energy(imgs)]
        if missing is not None:
            cells.append((np.nan, np.nan, np.nan))
        elif path in done:  # vid.stab has no use for a gyro: the same output
            cells.append(done[path][1])
        else:
            dst = work / tag / "vidstab"
            run_vidstab(src, dst)
            cells.append(hf_energy(_frames(dst)))
        done[path] = (src, cells[-1])
        stab = work / tag / ("stab_gyro" if method else "stab")
        run_unjello(src, stab, "--stabilize", *extra, *method)
        cells.append(hf_energy(_frames(stab)))
        zooms = [f.get("zoom", 1.0) for f in json.loads(
            stab.with_suffix(".json").read_text())["frames"]]
        # The high-frequency energy: translation and rotation together (px^2 a frame).
        energy = " / ".join(f"{a * a + b * b:.2f} +- {sd:.2f}" if np.isfinite(a) else "-"
                            for a, b, sd in cells)
        print(f"{name:26}" + "".join(f"{a:9.2f} / {b:4.2f}" if np.isfinite(a) else
                                     f"{'skipped':>16}" for a, b, _ in cells)
              + f"   {min(zooms):.3f}-{max(zooms):.3f}   {energy}", flush=True)


def speed(work: Path, frames: int = 150) -> None:
    # 150 frames: the stabiliser holds about 36 frames back, which on a clip of a few
    # dozen frames keeps the encoder waiting at the end (in-process profile of 40 frames:
    # 9.33 -> 10.07 s, 0.43 s of it waiting); a real clip is longer.
    print(f"\n3. speed, 1080p ({frames} frames of a simulated hand-held pan, x264): seconds")
    actual, _ = handheld("pan + shake", frames)
    sims = simulate(data.astronaut(), actual, SensorTiming(0.8), frames, size=(1920, 1080))
    src = work / "speed_in"
    _write([cv2.cvtColor(s.rolling, cv2.COLOR_RGB2BGR) for s in sims], src)
    clip = work / "speed.mp4"
    subprocess.run(["ffmpeg", "-v", "error", "-y", "-framerate", "30", "-i",
                    str(src / "%05d.png"), "-c:v", "libx264", "-crf", "18", "-pix_fmt",
                    "yuv420p", str(clip)], check=True)
    rounds: dict[str, list[float]] = {"without --stabilize": [], "with --stabilize": []}
    for _ in range(2):  # alternating, so both see the same machine
        for label, extra in (("without --stabilize", []), ("with --stabilize", ["--stabilize"])):
            t0 = time.perf_counter()
            subprocess.run([*UNJELLO, "correct", str(clip), "-o", str(work / "out.mp4"), "-y",
                            "--readout", "0.8", *extra], check=True, capture_output=True)
            rounds[label].append(time.perf_counter() - t0)
    ratios = [b / a for a, b in zip(*rounds.values(), strict=True)]
    print("   " + "; ".join(f"{k}: " + ", ".join(f"{v:.1f}" for v in ts) + " s"
                           for k, ts in rounds.items())
          + "; ratio per round " + ", ".join(f"{r:.3f}" for r in ratios))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=90, help="frames of each clip")
    ap.add_argument("--speed", action="store_true", help="also time 1080p (needs ffmpeg)")
    ap.add_argument("--speed-frames", type=int, default=150)
    ap.add_argument("--skip-real", action="store_true")
    ap.add_argument("--skip-simulated", action="store_true")
    ap.add_argument("--only", default="", help="real clips whose name contains this")
    args = ap.parse_args()
    missing = vidstab_missing()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        if not args.skip_simulated:
            simulated(work, missing, args.frames)
            walk(work, missing, args.frames)
        if not args.skip_real:
            real(work, missing, args.frames, args.only)
        if args.speed:
            if shutil.which("ffmpeg") is None:
                print("\n3. speed skipped: no ffmpeg to encode the 1080p clip")
            else:
                speed(work, args.speed_frames)


if __name__ == "__main__":
    main()
