"""A VapourSynth filter: ``clip = unjello.vapoursynth.correct(clip, readout=0.9)``.

The motion of the whole clip is measured once, when :func:`correct` is called (frames in
order, as ``unjello correct`` reads them, with the same method and settings); each frame
is then warped when VapourSynth asks for it, in any order, so ``vspipe`` of frames 100-120
alone gives the frames of the whole run. The frames keep their format (YUV 4:2:0, 4:2:2,
4:4:4 or RGB, 8 to 16 bits); their properties carry the frame's diagnostics
(``UnjelloOk``, ``UnjelloFallback``, ``UnjelloKept``, ``UnjelloFolds``,
``UnjelloConfidence``).

VapourSynth R81 ships as a self-contained wheel for CPython 3.12 and newer
(``pip install 'unjello[vapoursynth]'``); source plugins such as ``vapoursynth-bestsource``
come from PyPI too::

    import vapoursynth as vs
    import unjello.vapoursynth as uvs
    clip = vs.core.bs.VideoSource("in.mp4")
    clip = uvs.correct(clip, readout=0.9)
    clip.set_output()

Memory: the measured motion is held for every frame (the dense method's per-pixel field
and its neighbours' flows on the working copy: about 3 MB a frame at the default width).
"""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any

import numpy as np

from .clip import resolve_timing
from .config import CorrectionConfig
from .errors import MissingExtraError, SettingsError
from .io.video import PIPE
from .pipeline import Corrector
from .trajectory import FrameMotion
from .warp.warper import PictureWarper

__all__ = ["correct"]


def _vs() -> Any:
    try:
        import vapoursynth
    except ImportError:
        raise MissingExtraError("the VapourSynth filter needs VapourSynth (CPython 3.12+): "
                                "pip install 'unjello[vapoursynth]'") from None
    return vapoursynth


def correct(clip: Any, *, readout: float | str | None = None,
            config: CorrectionConfig | None = None, **options: Any) -> Any:
    """Correct a VapourSynth clip: its motion measured now, each frame warped on request.

    Parameters
    ----------
    clip : vapoursynth.VideoNode
        Constant format and size; YUV or RGB, integer samples of 8 to 16 bits.
    readout : float or str, optional
        As ``unjello correct --readout`` (a fraction, or ``"15.7ms"`` at the clip's frame
        rate); ``"auto"`` is not offered here (``unjello estimate-readout`` on the file).
    config : CorrectionConfig, optional
        The settings to start from (default ``CorrectionConfig()``).
    **options
        Any option of :class:`~unjello.config.CorrectionConfig` by its flat name
        (``method``, ``direction``, ``vibration``, ``stabilize``, ...), as in a preset.

    Returns
    -------
    vapoursynth.VideoNode
        The corrected clip, same format, length and frame rate.
    """
    vs = _vs()
    fmt = clip.format
    if fmt is None or clip.width == 0 or clip.height == 0:
        raise SettingsError("the clip must have one format and size throughout")
    if fmt.sample_type != vs.INTEGER or not 8 <= fmt.bits_per_sample <= 16:
        raise SettingsError(f"{fmt.name}: give integer samples of 8 to 16 bits")
    if fmt.color_family not in (vs.YUV, vs.RGB, vs.GRAY):
        raise SettingsError(f"{fmt.name}: give a YUV, RGB or grey clip")
    given = dict(options, **({"readout": readout} if readout is not None else {}))
    cfg = (config or CorrectionConfig()).with_options(origin="VapourSynth", **given)
    if cfg.readout == "auto" or cfg.method == "gyro":
        raise SettingsError("the VapourSynth filter takes a readout (not auto) and the dense "
                            "or paper method: it sees frames, not the file")
    fps = float(clip.fps) if clip.fps.numerator else 30.0
    timing = resolve_timing(cfg, path=Path(PIPE), video_fps=fps).timing
    rgb = fmt.color_family == vs.RGB
    dtype = np.uint8 if fmt.bits_per_sample == 8 else np.uint16

    def picture(frame: Any) -> list[np.ndarray]:
        planes = [np.asarray(frame[p], dtype=dtype) for p in range(fmt.num_planes)]
        return [np.dstack(planes)] if rgb else [p.copy() for p in planes]

    # The motion, measured once in order (the pictures are not warped: only=set()).
    corrector = Corrector(timing, cfg, max_value=float((1 << fmt.bits_per_sample) - 1),
                          fps=fps, only=set())
    motions: dict[int, FrameMotion] = {}
    for n, frame in enumerate(clip.frames(close=True)):
        motions.update((fm.index, fm) for _, fm in corrector.push(picture(frame), float(n)))
    motions.update((fm.index, fm) for _, fm in corrector.flush())
    last = clip.num_frames - 1
    # Frame n + k at n, for every offset the warp reads (the ends repeated, not used).
    offsets = [k for r in range(1, PictureWarper.REACH + 1) for k in (-r, r)]
    shifted = [_shifted(clip, k) for k in offsets]

    lock = threading.Lock()  # VapourSynth asks from several threads; the warper reuses buffers

    def render(n: int, f: list[Any]) -> Any:
        fm = motions[n]
        around = {k: picture(g) if 0 <= n + k <= last else None
                  for k, g in zip(offsets, f[1:], strict=True)}
        with lock:
            out = corrector.warp(picture(f[0]), fm, around)
        planes = [out[0][..., k] for k in range(3)] if rgb else out
        dst = f[0].copy()
        for p, plane in enumerate(planes):
            np.copyto(np.asarray(dst[p]), plane)
        dst.props["UnjelloOk"] = int(fm.ok)
        dst.props["UnjelloFallback"] = float(fm.diagnostics.fallback)
        dst.props["UnjelloKept"] = float(fm.diagnostics.kept)
        dst.props["UnjelloFolds"] = float(fm.diagnostics.folds)
        dst.props["UnjelloConfidence"] = float(fm.confidence)
        return dst

    return clip.std.ModifyFrame([clip, *shifted], render)


def _shifted(clip: Any, k: int) -> Any:
    """Return ``clip`` with frame ``n + k`` at ``n`` (its first or last frame repeated)."""
    n = clip.num_frames
    if n < 2 or k == 0:
        return clip
    if abs(k) >= n:
        return clip[0] * n if k < 0 else clip[-1] * n
    return clip[0] * (-k) + clip[:k] if k < 0 else clip[k:] + clip[-1] * k
