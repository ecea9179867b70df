"""Where a clip breaks: cuts, flashes, a changed picture size.

Edited footage, joined clips and live captures break: the frame after a cut shows
another scene, a flash lights one frame, a stream changes its picture size. No flow,
camera trajectory or neighbour's pixels may reach across such a break (the frames beside
it tore, and pieces of one scene filled the edge of the other), so the corrector ends the
stretch there and corrects the frames on either side as a clip's last and first
(:class:`unjello.corrector.Corrector`). :class:`Breaks` decides, one frame late, from
small grey copies:

* **a cut**: the tiles of the later frame, each found where it matches the earlier frame
  best, correlate below :data:`SIMILAR` (zero-mean, normalised; :func:`similarity`); the
  two frames' tones, each scaled to the same mean grey, differ by more than
  :data:`TONES` (:func:`tones`): a pan that blurs sharp texture correlates as poorly
  but keeps its tones; and the shift of the pair before or after does not explain the
  pair either: a pan of half the width a frame past near poles shares as little with
  the frame before, but keeps the pace of the pairs around it. A fade changes none of
  these (it scales the picture), and so keeps its motion;
* **not a flash**: a frame lit by a flash keeps its motion (the flow matches patches
  by their shape, not their level): broken off, it came out uncorrected, and the
  matrix's flashes lost 0.01-0.17x (``docs/matrix.md``);
* **streams joined**: said by the reader, where the picture size changes (the frames are
  scaled to the first size first, as ffmpeg scales them to its output's size) or the
  timestamps start over (carried on, as ffmpeg's concatenation does).
"""

from __future__ import annotations

from collections import deque

import cv2
import numpy as np

__all__ = ["Breaks", "SIMILAR", "TONES", "LIT", "shift", "similarity", "tones"]

#: Width of the grey copies compared (px): large enough for a scene's layout, small
#: enough that noise, blur and rolling-shutter skew do not count.
THUMB = 96
#: The copies are compared in this many tiles each way (:func:`similarity`).
TILES = 4
#: Tiles flatter than this grey-level standard deviation (0-255) do not vote: a flat sky
#: matches anything.
FLAT = 3.0
#: A pair is a cut where its tiles match below SIMILAR, its tones differ by over TONES, and
#: no neighbouring pair's shift explains it (:func:`similarity`; ``docs/tuning.md#similar``).
SIMILAR, TONES = 0.6, 0.15
#: Two frames both darker than this mean grey level (0-255) are not compared: too little
#: light to tell a cut from noise (a fade's last frames, black frames between two shots).
LIT = 24.0


def _thumb(luma: np.ndarray) -> np.ndarray:
    h, w = luma.shape[:2]
    size = (THUMB, max(8, round(h * THUMB / w))) if w >= h else (max(8, round(w * THUMB / h)),
                                                                  THUMB)
    return cv2.resize(np.asarray(luma, np.float32), size, interpolation=cv2.INTER_AREA)


def shift(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Return the whole copy's shift ``d`` with ``b(p) ~ a(p - d)``.

    Phase correlation of the copies, each less its mean and under a Hann window, laid on
    a field twice their size: a pan of half the width a frame is not read as its alias.
    """
    h, w = a.shape
    win = cv2.createHanningWindow((w, h), cv2.CV_32F)

    def padded(x: np.ndarray) -> np.ndarray:
        return cv2.copyMakeBorder((x - x.mean()) * win, h // 2, h - h // 2, w // 2,
                                  w - w // 2, cv2.BORDER_CONSTANT, value=0)

    return np.array(cv2.phaseCorrelate(padded(a), padded(b))[0])


def similarity(a: np.ndarray, b: np.ndarray, moved: np.ndarray | None = None) -> float:
    """How well grey copy ``b`` is made of pieces of ``a``, moved: about 1 the same scene.

    ``b`` is cut into :data:`TILES` x :data:`TILES` tiles; each is looked for in ``a``
    within an eighth of the width around where the whole frame's shift (:func:`shift`,
    or ``moved``) puts it (zero-mean normalised correlation, :func:`cv2.matchTemplate`),
    so that each tile may move its own way (a near pole, a moving object, parallax) and
    a fast pan is followed. The median of the best correlations of the tiles with texture
    whose centre the shift keeps over ``a`` (in a pan of half the width a frame, half the
    tiles show what the earlier frame never saw); 1 where no tile has texture. A frame
    of another scene matches nowhere.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> img = cv2.GaussianBlur(rng.uniform(0, 255, (40, 70)).astype(np.float32), (0, 0), 2)
    >>> bool(similarity(img[:, :64], img[:, 5:69]) > 0.95)
    True
    >>> bool(similarity(img[:, :64], np.ascontiguousarray(img[::-1, 6:])) < 0.8)
    True
    """
    h, w = b.shape
    dx, dy = shift(a, b) if moved is None else moved
    sx, sy = int(round(dx)), int(round(dy))
    reach = max(2, w // 8)
    px, py = reach + abs(sx), reach + abs(sy)
    pad = cv2.copyMakeBorder(a, py, py, px, px, cv2.BORDER_CONSTANT, value=float(a.mean()))
    best: list[float] = []
    seen: list[float] = []  # of tiles the shift keeps over ``a`` (not entering content)
    ty, tx = h // TILES, w // TILES
    for i in range(TILES):
        for j in range(TILES):
            tile = np.ascontiguousarray(b[i * ty:(i + 1) * ty, j * tx:(j + 1) * tx])
            y0, x0 = py + i * ty - sy - reach, px + j * tx - sx - reach
            area = pad[y0:y0 + ty + 2 * reach, x0:x0 + tx + 2 * reach]
            if tile.std() < FLAT:  # a flat sky matches anything
                continue
            best.append(float(cv2.matchTemplate(area, tile, cv2.TM_CCOEFF_NORMED).max()))
            cx, cy = (j + 0.5) * tx - sx, (i + 0.5) * ty - sy
            if 0 <= cx < w and 0 <= cy < h:
                seen.append(best[-1])
    return float(np.median(seen or best)) if best else 1.0


def tones(a: np.ndarray, b: np.ndarray) -> float:
    """How much two grey copies' tones differ, each scaled to the same mean (0-1).

    One less the intersection of their 32-bin histograms, after scaling each copy to a
    mean of 100: a fade (a gain) changes nothing, another scene usually much.
    """
    hists = [np.histogram(c * (100.0 / max(float(c.mean()), 1e-3)), bins=32,
                          range=(0, 256))[0] / c.size for c in (a, b)]
    return float(1.0 - np.minimum(*hists).sum())


class Breaks:
    """Decide where a clip breaks, one frame late: the frame after a break tells too.

    :meth:`add` each frame in turn; :meth:`before` then says whether the clip breaks
    before the frame added last (``1``) or the one before it (``2``, decided with the
    frame after it).

    Attributes
    ----------
    evidence : dict
        The last decision's measurements: ``similarity`` (:func:`similarity`), ``light``
        (the ratio of the mean grey levels, at least 1) and, where the similarity is low,
        ``tones`` (:func:`tones`) and ``pace`` (the similarity at the shift of the pair
        before or after it, the better).
    """

    def __init__(self) -> None:
        # The last three frames: (grey copy, mean, joined, shift from the frame before).
        self._frames: deque[tuple[np.ndarray, float, str | None, np.ndarray | None]] = deque(
            maxlen=3)
        self.evidence: dict[str, float] = {}

    def add(self, luma: np.ndarray, joined: str | None = None) -> None:
        """Add the next frame's grey levels (0-255).

        ``joined``: the reader found two streams joined before it (``'size'``, ``'time'``).
        """
        small = _thumb(luma)
        prev = self._frames[-1][0] if self._frames else None
        d = shift(prev, small) if prev is not None and prev.shape == small.shape else None
        self._frames.append((small, float(small.mean()), joined, d))

    def before(self, back: int) -> str | None:
        """Return why the clip breaks before the frame added ``back`` frames ago, or None.

        ``back`` is 1 for the frame added last, 2 for the one before it.

        Returns
        -------
        str or None
            ``'size'`` or ``'time'`` (streams joined), ``'cut'``, or None where the
            stretch goes on.
        """
        self.evidence = {}
        frames = list(self._frames)
        k = len(frames) - back  # the frame whose start is decided
        if k <= 0:
            return None
        (a, ma, _, _), (b, mb, joined, d) = frames[k - 1], frames[k]
        if joined:
            return joined
        if max(ma, mb) < LIT or d is None:
            return None
        sim = similarity(a, b)
        self.evidence = {"similarity": round(sim, 3),
                         "light": round(max(ma, mb) / min(ma, mb), 3)}
        if sim >= SIMILAR:
            return None
        self.evidence["tones"] = round(tones(a, b), 3)
        if self.evidence["tones"] <= TONES:
            return None
        # A pan keeps its pace: where the shift of the pair before or after explains
        # this pair (the frames' own shift, measured, can be an alias's).
        around = [frames[k - 1][3]] + ([frames[k + 1][3]] if k + 1 < len(frames) else [])
        pace = max((similarity(a, b, o) for o in around if o is not None), default=0.0)
        self.evidence["pace"] = round(pace, 3)
        return None if pace >= SIMILAR else "cut"
