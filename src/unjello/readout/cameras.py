"""A camera database: readout time, scan direction and lens of 9,000 camera modes.

The table (``data/cameras.json.gz``) is built by ``scripts/camera_table.py`` from the
Gyroflow community's lens profiles (CC0): one row per brand, model, lens or setting,
calibrated size and frame rate, with the median of the readout times its profiles state
(ms; negative: bottom to top), how many state one and how many of those agree within 5 %,
and the median camera matrix and fisheye distortion. The profiles are user-contributed and
noisy, so a match says how many profiles it rests on and how far they spread.

Matching a clip (:func:`match`): the camera's rows with a readout, those of the clip's
aspect ratio and frame rate first (a sensor mode is its aspect and rate; the output size is
often scaled), then the frame rate alone, then the aspect alone, then any.
"""

from __future__ import annotations

import gzip
import json
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources

import numpy as np

from ..errors import SettingsError

__all__ = ["CameraMode", "CameraMatch", "camera_name", "table", "search", "match"]


def camera_name(brand: str, model: str) -> str:
    """Brand and model as one name, the brand once (``GoPro``, ``GoPro Max``: ``GoPro Max``).

    Examples
    --------
    >>> camera_name("GoPro", "HERO5 Black"), camera_name("GoPro", "GoPro Max")
    ('GoPro HERO5 Black', 'GoPro Max')
    """
    brand, model = " ".join(brand.split()), " ".join(model.split())
    return model if model.lower().startswith(brand.lower()) else f"{brand} {model}".strip()


@dataclass(frozen=True)
class CameraMode:
    """One row of the table: a camera in one mode, summarised over its profiles."""

    brand: str
    model: str
    mode: str
    width: int
    height: int
    fps: float
    profiles: int
    readout_ms: float | None
    readout_n: int
    readout_agree: int
    fx: float | None
    fy: float | None
    cx: float | None
    cy: float | None
    k: tuple[float, ...] | None

    @property
    def name(self) -> str:
        """Brand and model (:func:`camera_name`)."""
        return camera_name(self.brand, self.model)


@dataclass(frozen=True)
class CameraMatch:
    """What the table says of a clip's camera.

    Attributes
    ----------
    camera : str
        The camera matched.
    readout_ms : float
        The readout most of the modes' profiles agree on (ms, positive; a value they
        state, not a mean).
    direction : str
        ``top-bottom``, or ``bottom-top`` where the profiles state negative readouts.
    profiles, agree : int
        Profiles stating a readout for those modes, and how many within 5 % of it.
    spread : tuple of float
        Smallest and largest readout they state (ms).
    modes : str
        Which modes were used (``its 1.78:1 modes at 29.97 fps``, ``any of its modes``...).
    focal : float or None
        Focal length in pixels of the clip's width (from modes of its aspect ratio).
    k : tuple of float or None
        Fisheye distortion coefficients of those modes.
    same_aspect : bool
        Whether those modes have the clip's aspect ratio.
    """

    camera: str
    readout_ms: float
    direction: str
    profiles: int
    agree: int
    spread: tuple[float, float]
    modes: str
    focal: float | None = None
    k: tuple[float, ...] | None = None
    #: Whether the modes used share the clip's aspect ratio (a sensor mode's readout is
    #: its own: another aspect's is a guess). False where the clip's size is unknown.
    same_aspect: bool = False
    #: The table's rows the readout was taken from (``unjello cameras`` marks them).
    used: tuple[CameraMode, ...] = ()

    def describe(self) -> str:
        """One line: the readout, and what it rests on."""
        lo, hi = self.spread
        rng = f"{lo:.4g}-{hi:.4g} ms" if hi - lo > 0.01 else f"{lo:.4g} ms"
        return (f"camera database: {self.camera}, {self.modes}: readout {self.readout_ms:.4g} ms "
                f"({self.agree} of {self.profiles} profile(s) stating one agree; {rng})")


@lru_cache(maxsize=1)
def table() -> tuple[CameraMode, ...]:
    """Return every row of the packaged table."""
    raw = resources.files("unjello").joinpath("data", "cameras.json.gz").read_bytes()
    doc = json.loads(gzip.decompress(raw))
    cols = doc["columns"]
    out = []
    for row in doc["rows"]:
        r = dict(zip(cols, row, strict=True))
        out.append(CameraMode(r["brand"], r["model"], r["mode"], int(r["w"]), int(r["h"]),
                              float(r["fps"]), int(r["profiles"]), r["readout_ms"],
                              int(r["readout_n"]), int(r["readout_agree"]), r["fx"], r["fy"],
                              r["cx"], r["cy"], tuple(r["k"]) if r["k"] else None))
    return tuple(out)


def _norm(text: str) -> str:
    return " ".join(text.lower().replace("_", " ").split())


def search(text: str = "") -> list[CameraMode]:
    """Return the rows whose brand, model or mode contain every word of ``text``."""
    words = _norm(text).split()
    return [m for m in table()
            if all(w in _norm(f"{m.brand} {m.model} {m.mode}") for w in words)]


def _camera_rows(camera: str, family: bool = False) -> list[CameraMode]:
    """Rows of one camera named by the user or by its file (brand and model).

    ``family``: a name that fits several cameras (a file that says only ``GoPro``) gives
    the rows of them all instead of an error.
    """
    want = _norm(camera)
    rows = [m for m in table() if want in (_norm(m.name), _norm(f"{m.brand} {m.model}"),
                                           _norm(m.model))]
    if rows:
        return rows
    partial = [m for m in table() if want in _norm(f"{m.brand} {m.model}")]
    names = sorted({m.name for m in partial})
    if len(names) > 1 and not family:
        shown = ", ".join(names[:6]) + (", ..." if len(names) > 6 else "")
        raise SettingsError(f"camera {camera!r} matches {len(names)} cameras ({shown}); "
                            "name one (see `unjello cameras`)")
    return partial


def match(camera: str, width: int | None = None, height: int | None = None,
          fps: float | None = None, *, family: bool = False) -> CameraMatch | None:
    """Return what the table says of a clip's camera (the module notes give the order).

    Parameters
    ----------
    camera : str
        Brand and model (``GoPro HERO5 Black``), or the model alone where it is unique.
    width, height : int, optional
        The clip's size (its aspect ratio picks the modes).
    fps : float, optional
        The clip's frame rate.
    family : bool
        Where ``camera`` fits several cameras (``GoPro``), pool their profiles (the
        match is named ``GoPro (45 cameras)``; its ``agree`` says whether they agree)
        instead of raising.

    Returns
    -------
    CameraMatch or None
        None when the camera is not in the table or none of its profiles states a
        readout.

    Raises
    ------
    SettingsError
        If ``camera`` names several cameras (and not ``family``).
    """
    rows = _camera_rows(camera, family)
    names = {m.name for m in rows}
    timed = [m for m in rows if m.readout_ms]
    if not timed:
        return None

    ratio = width / height if width and height else 0.0
    rate = float(fps or 0.0)

    def same_aspect(m: CameraMode) -> bool:
        return ratio > 0 and abs(m.width / m.height - ratio) < 0.01 * ratio

    def same_fps(m: CameraMode) -> bool:
        return rate > 0 and abs(m.fps - rate) < 0.01 * rate

    aspect = f"{ratio:.2f}:1" if ratio else ""
    tiers = [(lambda m: same_aspect(m) and same_fps(m), f"its {aspect} modes at {fps:g} fps"
              if fps else ""),
             (same_fps, f"its modes at {fps:g} fps" if fps else ""),
             (same_aspect, f"its {aspect} modes"),
             (lambda m: True, "any of its modes")]
    picked, label = timed, tiers[-1][1]
    for keep, label in tiers:  # noqa: B007 - the tier that picked is the one said
        picked = [m for m in timed if keep(m)]
        if picked:
            break
    sized = bool(ratio) and all(same_aspect(m) for m in picked)
    if ratio and not sized:  # say which sensor modes the readout is borrowed from
        sizes = sorted({f"{m.width}x{m.height}" for m in picked})
        label += (f" ({', '.join(sizes[:3])}{', ...' if len(sizes) > 3 else ''}; "
                  f"none is {aspect})")
    signed = np.concatenate([np.full(m.readout_n, m.readout_ms) for m in picked])
    values = np.abs(signed)
    med, agree = _best_supported(values)
    upward = int(np.sum(signed < 0)) > signed.size / 2
    lens = [m for m in rows if m.fx and same_aspect(m)] if width else []
    focal = (float(np.median([float(m.fx or 0.0) * float(width or 0) / m.width for m in lens]))
             if lens else None)
    ks = [m.k for m in lens if m.k]
    name = picked[0].name if len(names) == 1 else f"{camera} ({len(names)} cameras)"
    return CameraMatch(name, round(med, 4), "bottom-top" if upward else "top-bottom",
                       int(values.size), agree, (float(values.min()), float(values.max())), label,
                       focal, tuple(np.median(ks, axis=0).tolist()) if ks else None, sized,
                       tuple(picked))


def _best_supported(values: np.ndarray) -> tuple[float, int]:
    """Return the readout most profiles agree on (within 5 %), and how many do.

    A value the profiles state, not a mean between disagreeing ones: where they split
    (16.7 ms twice, 26.7 and 33.4 once) the larger group wins, and between groups of one
    size the value nearest their median.
    """
    support = [int(np.sum(np.abs(values - v) <= 0.05 * v)) for v in values]
    med = float(np.median(values))
    best = min(range(values.size), key=lambda i: (-support[i], abs(values[i] - med), values[i]))
    return float(values[best]), support[best]
