"""Frames through an encoder and back, in memory: the compression a clip goes through."""

from __future__ import annotations

import io
from collections.abc import Sequence

import av
import numpy as np

__all__ = ["h264_roundtrip", "degrade"]


def h264_roundtrip(frames: Sequence[np.ndarray], crf: int, fps: float = 30.0
                   ) -> list[np.ndarray]:
    """Encode RGB frames with libx264 (yuv420p, ``crf``, preset medium), decode them again.

    The same frames give the same result every time (no macroblock tree).

    Parameters
    ----------
    frames : sequence of ndarray of shape (H, W, 3), uint8
        Consecutive frames of one size (even width and height).
    crf : int
        x264's constant rate factor (14: near transparent, 28: visibly compressed).
    fps : float
        Frame rate written in the stream (the encoder's rate control reads it).

    Returns
    -------
    list of ndarray of shape (H, W, 3), uint8
    """
    buf = io.BytesIO()
    with av.open(buf, "w", format="mp4") as out:
        vs = out.add_stream("libx264", rate=round(fps))
        vs.height, vs.width = frames[0].shape[:2]
        vs.pix_fmt = "yuv420p"
        # Without the macroblock tree, which made this build of x264 encode the same
        # frames differently from run to run (and the scores of a degraded clip with it).
        vs.options = {"crf": str(int(crf)), "preset": "medium", "x264-params": "mbtree=0"}
        for f in frames:
            for p in vs.encode(av.VideoFrame.from_ndarray(np.ascontiguousarray(f),
                                                          format="rgb24")):
                out.mux(p)
        for p in vs.encode():
            out.mux(p)
    buf.seek(0)
    with av.open(buf) as c:
        return [fr.to_ndarray(format="rgb24") for fr in c.decode(video=0)]


def degrade(frames: Sequence[np.ndarray], seed: int = 0, noise: float = 3.0,
            crf: int | None = 26, fps: float = 30.0) -> list[np.ndarray]:
    """Return the frames as a camera delivers them: noisy, then compressed.

    Gaussian sensor noise of ``noise`` grey levels (from ``seed``; 0: none), then libx264
    at ``crf`` and back (:func:`h264_roundtrip`; None: not compressed).
    """
    out = list(frames)
    if noise > 0:
        rng = np.random.default_rng(seed)
        out = [np.clip(f + rng.normal(0, noise, f.shape), 0, 255).astype(np.uint8)
               for f in out]
    return h264_roundtrip(out, crf, fps) if crf is not None else out
