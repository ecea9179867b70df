"""A scene of straight edges: a street of buildings with windows, and poles.

For the readout's line cue (:mod:`unjello.readout.lines`): its verticals are vertical in
the world unless ``lean`` says otherwise (a shear: perspective, a leaning facade), and
the whole picture can be rolled (a camera not held level). Textured, so the flow finds
the motion everywhere.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["street_scene"]


def street_scene(size: tuple[int, int] = (960, 720), *, lean: float = 0.0, roll: float = 0.0,
                 seed: int = 0) -> np.ndarray:
    """Render buildings and poles as an RGB image.

    Parameters
    ----------
    size : (int, int)
        ``(width, height)`` of the image (make it larger than the frames panned over it).
    lean : float
        The scene's own lean of its verticals, dx/dy (a shear about the middle row;
        horizontals stay horizontal).
    roll : float
        Camera roll, radians: the whole picture rotated about its centre.
    seed : int
        Random layout.

    Returns
    -------
    ndarray of shape (height, width, 3), uint8
    """
    w, h = size
    rng = np.random.default_rng(seed)
    # A margin, so the shear and the rotation bring no empty corners in.
    m = int(0.25 * max(w, h) + abs(lean) * h)
    W, H = w + 2 * m, h + 2 * m
    img = np.zeros((H, W, 3), np.float32)
    img[:] = np.linspace(200, 150, H)[:, None, None] * np.array([0.8, 0.9, 1.0])
    ground = int(0.85 * H)
    x = 0
    while x < W:  # the facades, side by side
        bw = int(rng.integers(W // 14, W // 6))
        top = int(rng.integers(int(0.1 * H), int(0.5 * H)))
        colour = rng.uniform(60, 200, 3)
        img[top:ground, x:x + bw] = colour
        win_w, win_h = max(3, bw // 8), max(4, H // 40)
        for wy in range(top + win_h, ground - 2 * win_h, 2 * win_h):
            for wx in range(x + win_w, x + bw - 2 * win_w, 2 * win_w):
                img[wy:wy + win_h, wx:wx + win_w] = colour * rng.uniform(0.3, 0.6)
        x += bw + int(rng.integers(0, W // 40))
    img[ground:] = (90, 90, 95)
    for px in rng.integers(0, W, size=max(3, W // 120)):  # poles in front
        pw = int(rng.integers(3, 8))
        img[int(0.2 * H):ground + 4, px:px + pw] = rng.uniform(10, 50)
    # Texture for the flow: blurred noise, as surfaces have.
    noise = cv2.GaussianBlur(rng.normal(0, 18, (H, W)).astype(np.float32), (0, 0), 1.2)
    img += noise[..., None]
    centre = (W / 2.0, H / 2.0)
    shear = np.array([[1.0, lean, -lean * centre[1]], [0.0, 1.0, 0.0]], np.float32)
    out = cv2.warpAffine(img, shear, (W, H), flags=cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_REFLECT)
    if roll:
        rot = cv2.getRotationMatrix2D(centre, float(np.degrees(roll)), 1.0)
        out = cv2.warpAffine(out, rot, (W, H), flags=cv2.INTER_LINEAR,
                             borderMode=cv2.BORDER_REFLECT)
    return np.clip(out[m:m + h, m:m + w], 0, 255).astype(np.uint8)
