"""A matrix of simulated clips that every change to motion or warp is scored on.

A :class:`Case` names a camera motion, a scene, the camera (readout, frame rate, size,
scan direction) and what the clip went through (exposure blur, noise, CRF); a cut joins
two cases end to end. :func:`cases` lists the whole matrix (built from seeds, the same
on every run), :func:`ci_slice` its small clips that the test suite runs, :func:`build`
renders a case with its truth, and :func:`score` corrects it with a function the caller
passes (the simulator does not import the pipeline) and scores the result:

* ``ratio``: the mean displacement error (per pixel where the truth has layers) over the
  uncorrected error -- below 1 is better than leaving the clip alone;
* ``psnr_in`` / ``psnr_out``: PSNR against the global-shutter truth (12 px margin);
* ``background_in`` / ``background_out``: over a moving object's scene, PSNR of the
  background no object covers, in the frame or in the truth;
* ``cut_db``: for a cut, the PSNR of the two frames beside it corrected in one run, less
  that of the two parts corrected apart (0: the cut leaks nothing);
* ``core_ms``: CPU time of all threads per frame, in ms.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cache

import cv2
import numpy as np

from ..metrics import displacement_error, psnr, region_psnr
from ..timing import SensorTiming, to_top_bottom
from ..trajectory import FrameMotion, Trajectory
from .motion import Motion, Vibration
from .render import Layer, SimulatedFrame, simulate

__all__ = ["Case", "Clip", "KINDS", "TARGETS", "build", "cases", "ci_slice", "score"]

#: The families of motion the matrix reports one table each for, and each one's target:
#: the median error ratio (corrected over uncorrected) its cases must stay within.
TARGETS: dict[str, float] = {"pan": 0.25, "shake": 0.35, "walk": 0.35, "jello": 0.15,
                             "still": 1.0, "cut": 0.35, "fade": 0.35, "flash": 0.5}
KINDS = tuple(TARGETS)

#: The photographs of the ``photo`` scenes (``skimage.data``).
PHOTOS = ("astronaut", "coffee", "chelsea", "rocket", "hubble_deep_field")

Correct = Callable[[list[np.ndarray], SensorTiming, float], tuple[list[np.ndarray], Trajectory]]


@dataclass(frozen=True)
class Case:
    """One simulated clip of the matrix.

    Parameters
    ----------
    name : str
        Unique, stable: the key of the baseline.
    kind : str
        The family it is reported with (:data:`KINDS`).
    motion : str
        ``pan``, ``rest`` (a pan from still), ``stop``, ``whip``, ``diagonal``, ``tilt``,
        ``shake``, ``walk``, ``jello`` or ``still``.
    scene : str
        ``photo``, ``sharp`` (text, brick, gravel, coins), ``sky`` (a flat sky behind
        flat poles, 2.2 times as near), ``low`` (low texture), ``parallax``, ``spinner``
        ``object`` (a photo a quarter of the frame wide and 45 % as high crossing the
        scene) or ``tall`` (the same, the frame's whole height).
    speed : float
        Pans: share of the width a frame; ``object``: the object's own speed, likewise.
    jello : tuple
        ``(across, updown, drift[, during])``: (Hz, px at 640 wide) pairs each way, px/s
        of drift, the frame times it vibrates in (default throughout).
    then : Case, optional
        For a cut: the clip that follows (its own motion, scene and length).
    effect : str
        ``''``, ``'fade'`` (to black over the clip) or ``'flash'`` (one frame).
    """

    name: str
    kind: str
    motion: str
    scene: str = "photo"
    readout: float = 1.0
    fps: float = 30.0
    size: tuple[int, int] = (320, 180)
    frames: int = 16
    direction: str = "top-bottom"
    crf: int | None = None
    noise: float = 0.0
    exposure: float = 0.0
    speed: float = 0.05
    jello: tuple = ()
    image: str = "astronaut"
    then: Case | None = None
    effect: str = ""

    @property
    def timing(self) -> SensorTiming:
        """The camera's readout and scan direction (reference: the middle scanline)."""
        return SensorTiming(self.readout, self.direction)  # type: ignore[arg-type]

    @property
    def total(self) -> int:
        """Frames in the clip (both parts of a cut)."""
        return self.frames + (self.then.frames if self.then is not None else 0)


@dataclass
class Clip:
    """A rendered case: rolling-shutter frames and the truth of each.

    ``masks``: per frame, the pixels its displacement error is scored on (None: all);
    ``background``: per frame, the background no object covers (None without objects);
    ``cut``: the index of the first frame after a cut (None without).
    """

    rolling: list[np.ndarray]
    truth: list[np.ndarray]
    motions: list[FrameMotion]
    masks: list[np.ndarray | None]
    background: list[np.ndarray | None] = field(default_factory=list)
    cut: int | None = None


def _skimage(name: str) -> np.ndarray:
    from skimage import data  # the test images; correcting never needs them

    img = getattr(data, name)()
    return np.dstack([img] * 3) if img.ndim == 2 else img[..., :3]


@cache
def _sharp() -> np.ndarray:
    """Text, brick, gravel and coins, 2 x 2: sharp textures of every orientation."""
    tiles = [cv2.resize(_skimage(n), (512, 384), interpolation=cv2.INTER_AREA)
             for n in ("text", "brick", "gravel", "coins")]
    return np.vstack([np.hstack(tiles[:2]), np.hstack(tiles[2:])])


@cache
def _low() -> np.ndarray:
    """Low texture: the moon, blurred and at a third of its contrast."""
    moon = cv2.GaussianBlur(_skimage("moon").astype(np.float32), (0, 0), 4.0)
    return np.clip(100 + (moon - moon.mean()) / 3, 0, 255).astype(np.uint8)


@cache
def _sky() -> np.ndarray:
    """Return a flat sky (a gentle gradient) over the upper 55 %, gravel below."""
    ground = cv2.resize(_skimage("gravel"), (1024, 768), interpolation=cv2.INTER_AREA)
    out = ground.copy()
    top = int(0.55 * out.shape[0])
    ramp = np.linspace(0, 1, top)[:, None, None]
    out[:top] = (np.array([150, 190, 235]) * (1 - ramp) + np.array([190, 215, 240]) * ramp)
    return out


def _scene(case: Case) -> np.ndarray:
    if case.scene == "sharp":
        return _sharp()
    if case.scene == "low":
        return _low()
    if case.scene == "sky":
        return _sky()
    return _skimage(case.image)


def _px(case: Case, share: float) -> float:
    """Return a share of the width a frame in px a frame at the case's size."""
    return share * case.size[0]


def _motion(case: Case) -> Callable[[np.ndarray], np.ndarray]:
    w, fps, n = case.size[0], case.fps, case.frames
    v = _px(case, case.speed)
    scale = w / 640.0
    t = np.arange(-4.0, n + 6.0, 0.25)
    if case.motion == "pan":
        return Motion("pan", fps, speed=v)
    if case.motion == "rest":
        return Motion.from_rest(v, 0.0, start=3.0, ramp=3.0, until=n + 6.0)
    if case.motion == "stop":
        return Motion("stop", fps, speed=v, stop_at=n / 2.0)
    if case.motion == "whip":
        return Motion("whip", fps, speed=v, start_at=3.0)
    if case.motion == "diagonal":
        return Motion("diagonal", fps, speed=v)
    if case.motion == "tilt":
        return Motion("spline", fps, knots=(tuple(t), tuple(0.0 * t), tuple(v * t)))
    if case.motion == "shake":
        return Motion("shake", fps, amplitude=scale)
    if case.motion == "walk":
        return Motion("walk", fps, speed=v, amplitude=scale)
    if case.motion == "jello":
        across, updown, drift, *during = case.jello
        return Vibration(tuple((f, a * scale) for f, a in across),
                         tuple((f, a * scale) for f, a in updown), drift * scale, fps,
                         *during)
    if case.motion == "still":
        return Motion("pan", fps, speed=0.0)
    raise ValueError(f"unknown motion {case.motion!r}")


def _crossing(case: Case, camera: Callable[[np.ndarray], np.ndarray]) -> list[Layer]:
    """Return a photo a quarter of the frame wide crossing the middle of the clip at ``speed``."""
    w, h = case.size
    if case.direction in ("left-right", "right-left"):
        w, h = h, w
    lw, lh = max(8, w // 4), h if case.scene == "tall" else max(8, int(0.45 * h))
    tex = to_top_bottom(cv2.resize(_skimage("coffee"), (lw, lh), interpolation=cv2.INTER_AREA),
                        case.direction).astype(np.float32)
    alpha = np.ones(tex.shape[:2], np.float32)
    alpha[:, [0, -1]] = alpha[[0, -1], :] = 0.5
    own = _px(case, case.speed)
    x0 = w / 2 - tex.shape[1] / 2 - own * case.frames / 2

    def path(t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, np.float64)
        return camera(t) + np.stack([own * t, 0.0 * t], axis=-1)

    return [Layer(tex, alpha, (x0, 0.0 if case.scene == "tall" else 0.3 * h), path)]


def _layers(case: Case, camera: Callable[[np.ndarray], np.ndarray]) -> str | list[Layer]:
    if case.scene == "sky":
        return "poles"
    if case.scene == "parallax":
        return "parallax"
    if case.scene == "spinner":
        return "propeller" if case.speed <= 0.05 else "wheel"
    if case.scene in ("object", "tall"):
        return _crossing(case, camera)
    return "planar"


def _render(case: Case) -> list[SimulatedFrame]:
    camera = _motion(case)
    return list(simulate(_scene(case), camera, case.timing, case.frames,  # type: ignore[arg-type]
                         size=case.size, exposure=case.exposure, layers=_layers(case, camera),
                         layer_image=_skimage("chelsea")))


def _gain(images: list[np.ndarray], gains: Sequence[float], lift: Sequence[float]
          ) -> list[np.ndarray]:
    return [np.clip(img.astype(np.float32) * g + o, 0, 255).astype(np.uint8)
            for img, g, o in zip(images, gains, lift, strict=True)]


def _background(sim: SimulatedFrame, case: Case) -> np.ndarray | None:
    """Return the background no object covers in the frame or at the reference time."""
    if case.scene not in ("object", "tall") or sim.layer is None:
        return None
    grow = int(np.ceil(_px(case, case.speed) * case.readout)) + 6
    obj = cv2.dilate((sim.layer != 0).astype(np.uint8), np.ones((2 * grow + 1,) * 2, np.uint8))
    return obj == 0


def build(case: Case) -> Clip:
    """Render a case: its rolling-shutter frames (degraded as the case says) and truth."""
    parts = [case] + ([case.then] if case.then is not None else [])
    rolling: list[np.ndarray] = []
    truth: list[np.ndarray] = []
    motions: list[FrameMotion] = []
    masks: list[np.ndarray | None] = []
    background: list[np.ndarray | None] = []
    for part in parts:
        sim = _render(part)
        rolling += [s.rolling for s in sim]
        truth += [s.truth for s in sim]
        motions += [dataclasses.replace(s.motion, index=len(motions) + k)
                    for k, s in enumerate(sim)]
        # Spinners are scored on their background: the camera's motion.
        masks += [s.layer == 0 if part.scene == "spinner" and s.layer is not None else None
                  for s in sim]
        background += [_background(s, part) for s in sim]
    n = len(rolling)
    if case.effect == "fade":  # to a tenth of the light, evenly over the clip
        gains = np.linspace(1.0, 0.1, n)
        rolling, truth = _gain(rolling, gains, [0] * n), _gain(truth, gains, [0] * n)
    elif case.effect == "flash":  # one frame over-exposed, in the middle
        gains = [1.0] * n
        lift = [0.0] * n
        gains[n // 2], lift[n // 2] = 1.6, 50.0
        rolling, truth = _gain(rolling, gains, lift), _gain(truth, gains, lift)
    from ..io.roundtrip import degrade  # PyAV, at the edge

    rolling = degrade(rolling, len(case.name), case.noise, case.crf, case.fps)
    return Clip(rolling, truth, motions, masks, background,
                case.frames if case.then is not None else None)


def score(case: Case, correct: Correct) -> dict:
    """Correct a case with ``correct(frames, timing, fps)`` and score it (module docstring)."""
    clip = build(case)
    t0 = time.process_time()
    out, traj = correct(clip.rolling, case.timing, case.fps)
    cpu = time.process_time() - t0
    unc = np.mean([displacement_error(None, m, k)
                   for m, k in zip(clip.motions, clip.masks, strict=True)])
    err = np.mean([displacement_error(f, m, k)
                   for f, m, k in zip(traj.frames, clip.motions, clip.masks, strict=True)])
    row: dict = {"case": case.name, "kind": case.kind, "frames": case.total,
                 "uncorrected_px": round(float(unc), 4),
                 "ratio": round(float(err / unc), 4) if unc > 1e-6 else 0.0,
                 "psnr_in": round(float(np.mean([psnr(a, b, 12) for a, b in
                                                 zip(clip.rolling, clip.truth, strict=True)])), 2),
                 "psnr_out": round(float(np.mean([psnr(a, b, 12) for a, b in
                                                  zip(out, clip.truth, strict=True)])), 2),
                 "core_ms": round(1000 * cpu / case.total, 1),
                 "vibration": traj.vibration is not None,
                 "stretches": [s.as_json() for s in getattr(traj, "stretches", [])]}
    if any(b is not None for b in clip.background):
        keep = [(i, b) for i, b in enumerate(clip.background) if b is not None and b.any()]
        for key, images in (("background_in", clip.rolling), ("background_out", out)):
            row[key] = round(float(np.mean([region_psnr(images[i], clip.truth[i], b)
                                            for i, b in keep])), 2)
    if clip.cut is not None:
        k = clip.cut
        apart = (correct(clip.rolling[:k], case.timing, case.fps)[0]
                 + correct(clip.rolling[k:], case.timing, case.fps)[0])
        side = (k - 1, k)
        row["cut_db"] = round(float(np.mean([psnr(out[i], clip.truth[i], 12)
                                             - psnr(apart[i], clip.truth[i], 12)
                                             for i in side])), 2)
    return row


def _jello(rng: np.random.Generator, fps: float, drift: bool) -> tuple:
    """Vibration of 15-100 Hz (above half the frame rate mostly), 0.5-5 px, both axes."""
    top = min(100.0, 3.2 * fps)
    f = rng.uniform(15.0, top, 3)
    a = rng.uniform(0.5, 5.0, 3)
    across = ((round(float(f[0]), 1), round(float(a[0]), 2)),
              (round(float(f[1]), 1), round(float(a[1]) / 2, 2)))
    updown = ((round(float(f[2]), 1), round(float(a[2]) * 0.7, 2)),)
    return across, updown, round(float(rng.uniform(30.0, 90.0)), 1) if drift else 0.0


def cases() -> list[Case]:
    """Return the whole matrix: every case, built from fixed seeds (the same every run)."""
    rng = np.random.default_rng(76)
    out: list[Case] = []
    readouts = (0.3, 0.5, 0.7, 0.9, 1.0)
    directions = ("top-bottom", "top-bottom", "bottom-top", "left-right", "right-left")
    quality = ((None, 0.0, 0.0), (None, 0.0, 0.0), (14, 0.0, 0.0), (20, 2.0, 0.0),
               (28, 3.0, 0.3))

    def pick(seq: Sequence) -> object:
        return seq[int(rng.integers(len(seq)))]

    def camera(name: str, kind: str, motion: str, scene: str, **kw: object) -> Case:
        crf, noise, exposure = pick(quality)  # type: ignore[misc]
        base: dict = {"readout": pick(readouts), "fps": pick((24.0, 30.0, 30.0, 60.0)),
                      "crf": crf, "noise": noise, "exposure": exposure,
                      "image": pick(PHOTOS), "direction": "top-bottom"}
        if scene in ("photo", "sharp", "low"):
            base["direction"] = pick(directions)
        base.update(kw)
        return Case(name, kind, motion, scene, **base)

    # Pans: steady, from rest, stopping, whip, diagonal, tilt, over every scene.
    scenes = ("photo", "sharp", "sky", "low", "parallax", "spinner", "photo")
    for motion, speeds in (("pan", (0.02, 0.05, 0.1, 0.2)), ("rest", (0.05, 0.12)),
                           ("stop", (0.04, 0.08)), ("whip", (0.1, 0.18)),
                           ("diagonal", (0.03, 0.08)), ("tilt", (0.03, 0.07))):
        for k, scene in enumerate(scenes if motion == "pan" else scenes[:5]):
            v = speeds[k % len(speeds)]
            if scene == "sky":
                v = min(v, 0.1)
            out.append(camera(f"pan/{motion}/{scene}/{k}", "pan", motion, scene, speed=v,
                              frames=18 if motion in ("rest", "whip") else 14))
    out.append(camera("pan/pan/photo/640", "pan", "pan", "photo", speed=0.04, size=(640, 360),
                      frames=12))
    out.append(camera("pan/pan/sharp/1280", "pan", "pan", "sharp", speed=0.03,
                      size=(1280, 720), frames=8, crf=20, noise=2.0))
    # Hand shake and walks.
    for k, scene in enumerate(("photo", "sharp", "low", "parallax", "photo", "sky", "photo",
                               "sharp", "spinner", "photo", "low", "sharp")):
        out.append(camera(f"shake/{scene}/{k}", "shake", "shake", scene, frames=16))
    for k, scene in enumerate(("photo", "sharp", "parallax", "photo", "low", "photo", "sky",
                               "sharp")):
        out.append(camera(f"walk/{scene}/{k}", "walk", "walk", scene, speed=0.004,
                          frames=16))
    # Drone jello: 15-100 Hz, 0.5-5 px, both axes, with and without drift.
    # (Over texture the flow can follow, through light compression: jello under low
    # texture, or averaged away by a long exposure, leaves too little to measure.)
    for k in range(28):
        fps = float(pick((24.0, 30.0, 30.0, 30.0, 60.0)))
        scene = str(pick(("photo", "sharp")))
        size = (640, 360) if k % 6 == 5 else (320, 180)
        crf, noise, _ = pick(quality[:4])  # type: ignore[misc]
        out.append(camera(f"jello/{scene}/{k}", "jello", "jello", scene, fps=fps, size=size,
                          jello=_jello(rng, fps, drift=k % 2 == 0), frames=40,
                          readout=pick((0.6, 0.8, 0.9, 0.95, 1.0)), crf=crf, noise=noise,
                          exposure=0.0))
    # The drone clips issue 76 was filed with (640 x 360; px as given).
    sharp = {"kind": "jello", "motion": "jello", "scene": "sharp", "size": (640, 360)}
    out += [Case("jello/issue-40+23", **sharp, readout=0.95, frames=45, crf=14,
                 jello=(((40.0, 3.0), (23.0, 1.5)), ((40.0, 2.0), (31.0, 1.0)), 60.0)),
            Case("jello/issue-47+53", **sharp, readout=1.0, frames=60,
                 jello=(((47.0, 4.0), (53.0, 2.0)), ((41.0, 3.0),), 40.0)),
            Case("jello/issue-photos-17+27", "jello", "jello", "photo", readout=0.9,
                 frames=40, jello=(((17.0, 1.2), (27.0, 0.6)), ((21.0, 1.0),), 0.0)),
            Case("jello/issue-photos-38+24", "jello", "jello", "photo", readout=0.8,
                 frames=40, image="coffee",
                 jello=(((38.0, 2.0), (24.0, 1.0)), ((38.0, 1.0),), 80.0))]
    # A still camera: moving objects over a still background, spinners.
    for k in range(10):
        scene = "spinner" if k >= 7 else "object"
        out.append(camera(f"still/{scene}/{k}", "still", "still", scene,
                          speed=(0.02, 0.05, 0.08)[k % 3], frames=12,
                          size=(640, 360) if k == 3 else (320, 180),
                          readout=pick((0.7, 0.9, 1.0))))
    out.append(Case("still/object/issue-30px", "still", "still", "object", speed=30 / 640,
                     size=(640, 360), frames=12, crf=18, noise=1.0))
    # Cuts between two of these, fades and flashes.
    firsts = [c for c in out if c.kind in ("pan", "shake", "walk") and c.scene != "sky"
              and c.size == (320, 180)]
    for k in range(12):
        a, b = firsts[int(rng.integers(len(firsts)))], firsts[int(rng.integers(len(firsts)))]
        a2 = dataclasses.replace(a, frames=10, crf=None, noise=0.0, exposure=0.0,
                                 direction="top-bottom", readout=0.9, fps=30.0)
        b2 = dataclasses.replace(b, frames=10, crf=None, noise=0.0, exposure=0.0,
                                 direction="top-bottom", readout=0.9, fps=30.0,
                                 image=pick([p for p in PHOTOS if p != a.image]),
                                 scene="sharp" if a.scene != "sharp" else "photo")
        out.append(dataclasses.replace(a2, name=f"cut/{a.motion}-{b.motion}/{k}", kind="cut",
                                       then=b2))
    out.append(Case("cut/issue-cup-page", "cut", "pan", "photo", readout=0.9, size=(640, 360),
                    frames=10, image="coffee", speed=0.04,
                    then=Case("page", "shake", "shake", "sharp", readout=0.9,
                              size=(640, 360), frames=10)))
    for effect, count in (("fade", 6), ("flash", 6)):
        for k in range(count):
            base = firsts[int(rng.integers(len(firsts)))]
            out.append(dataclasses.replace(base, name=f"{effect}/{base.motion}/{k}",
                                           kind=effect, effect=effect, frames=14))
    # A drone that lands (vibrating for 30 frames, then not) and one that takes off.
    out += [Case(f"jello/{name}", "jello", "jello", "photo", readout=0.9, frames=60,
                 image="coffee", jello=(((38.0, 2.0), (24.0, 1.0)), ((31.0, 1.5),), 40.0,
                                        during))
            for name, during in (("lands", (-1e9, 30.0)), ("takes-off", (30.0, 1e9)))]
    # A photo as high as the frame crossing a still background (640 x 360, readout 1.0).
    out += [Case(f"still/tall/{image}-{px}px", "still", "still", "tall", image=image,
                 speed=px / 640, size=(640, 360), frames=12, crf=18, noise=1.0)
            for image in ("rocket", "astronaut") for px in (14, 30)]
    return out


#: The cases of :func:`ci_slice`: a few of every kind, small and short, that the default
#: corrects well (the slice guards what works; the whole matrix shows what does not).
CI = ("pan/pan/photo/0", "pan/whip/sharp/1", "pan/tilt/photo/0", "pan/pan/parallax/4",
      "pan/rest/low/3", "pan/stop/photo/0", "shake/photo/6", "shake/sharp/7",
      "shake/parallax/3", "walk/sharp/1", "walk/photo/0", "jello/photo/2", "jello/photo/10",
      "jello/issue-photos-38+24", "jello/sharp/0", "pan/tilt/sky/2", "still/object/0",
      "still/object/5", "still/spinner/9",
      "cut/pan-shake/2", "cut/tilt-whip/3", "cut/diagonal-walk/5", "fade/walk/3",
      "fade/shake/4", "flash/shake/0", "flash/pan/5")


def ci_slice() -> list[Case]:
    """Return the small cases the test suite runs (:data:`CI`)."""
    return [c for c in cases() if c.name in CI]
