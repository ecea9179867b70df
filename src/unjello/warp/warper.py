"""Scanline realignment (paper Sec. V.D, eq. 26): splatting, hole filling, fast remap.

Liang, Chang & Chen (2008), Sec. V.D. With the per-scanline velocity ``v'(t)`` known,
pixel ``s`` of frame ``n`` belongs at (eq. 26, in our time unit and readout ``rho``)

    p = s - integral from t_ref to t(s_y) of v'(t) dt,   t(s_y) = t_n + rho s_y / h,

where ``t_ref`` is the time of the reference scanline (the middle one in the paper, or
the first). The integral, ``Delta(s_y)``, depends only on the row, so all pixels of a
scanline move together (:func:`~unjello.timing.scanline_displacement`). Two ways to apply it:

* :func:`splat` -- the paper's forward mapping: the intensity of ``s`` is given to the
  four grid points nearest ``p``, each weighted inversely to its distance to ``p``;
  every grid point is normalised by the weights it received; pixels that received
  nothing are filled by averaging valid neighbours (cracks), and what is still empty
  (the area no scanline reached) is black, as in the paper's Fig. 10-11, or copied
  from the nearest valid pixel.
* :func:`remap` -- a backward warp of the same displacement with ``cv2.remap``:
  because ``Delta`` depends only on the row, the inverse of ``p_y = s_y - Delta_y(s_y)``
  is a 1-D monotone interpolation, so the backward map is exact, not a fixed point.
"""

from __future__ import annotations

from typing import Literal

import cv2
import numpy as np

from ..lens import Lens
from ..timing import SensorTiming, from_top_bottom, to_top_bottom
from ..trajectory import FrameMotion
from .bands import PlaneMaps, band_rows, warp_bands
from .fill.neighbours import edge_slopes, outside_share
from .fill.planes import NeighbourFill
from .front_layers import shown_objects
from .maps import compose_maps, frame_maps, grid_field, reframe_maps, remap_maps
from .scanlines import row_sources, shift_planes

__all__ = ["Fill", "WarpMode", "FILLS", "WARPS", "PictureWarper", "resample_displacement",
           "splat", "remap", "apply_maps", "fill_holes"]

Fill = Literal["black", "nearest"]
WarpMode = Literal["remap", "splat"]
FILLS: tuple[str, ...] = ("nearest", "black")
WARPS: tuple[str, ...] = ("remap", "splat")


def resample_displacement(displacement: np.ndarray, height: int, width_scale: float,
                          height_scale: float) -> np.ndarray:
    """Displacement for a plane of another resolution (e.g. 4:2:0 chroma).

    Parameters
    ----------
    displacement : ndarray of shape (h, 2)
        Per-scanline displacement at full resolution.
    height : int
        Rows of the target plane.
    width_scale, height_scale : float
        Target size divided by full size along x and y.

    Returns
    -------
    ndarray of shape (height, 2)
    """
    h = displacement.shape[0]
    src_rows = (np.arange(height) + 0.5) / height_scale - 0.5
    rows = np.arange(h, dtype=np.float64)
    out = np.stack([np.interp(src_rows, rows, displacement[:, k]) for k in range(2)], axis=1)
    return out * np.array([width_scale, height_scale])


def apply_maps(image: np.ndarray, maps: tuple[np.ndarray, np.ndarray], fill: Fill = "nearest"
               ) -> np.ndarray:
    """Backward warp ``out(p) = image(maps(p))``, bilinear (:func:`cv2.remap`).

    Parameters
    ----------
    image : ndarray of shape (h, w[, c])
    maps : tuple of ndarray of shape (h, w), float32
        Source x and y of every output pixel.
    fill : {'nearest', 'black'}
        What to put where the source lies outside the frame.
    """
    border = cv2.BORDER_REPLICATE if fill == "nearest" else cv2.BORDER_CONSTANT
    return cv2.remap(image, maps[0], maps[1], cv2.INTER_LINEAR, borderMode=border,
                     borderValue=0)


def remap(image: np.ndarray, displacement: np.ndarray, fill: Fill = "nearest"
          ) -> tuple[np.ndarray, np.ndarray]:
    """Backward warp of eq. 26's displacement with bilinear ``cv2.remap``.

    Parameters
    ----------
    image : ndarray of shape (h, w[, c])
        Frame in top-bottom orientation.
    displacement : ndarray of shape (h, 2)
        Per-scanline ``Delta`` from :func:`~unjello.timing.scanline_displacement`.
    fill : {'nearest', 'black'}
        What to put where no scanline lands.

    Returns
    -------
    out : ndarray like ``image``
        The corrected frame.
    valid : ndarray of bool, shape (h, w)
        True where the output was sampled from inside the frame.
    """
    h, w = image.shape[:2]
    map_x, map_y = remap_maps(displacement, w)
    out = apply_maps(image, (map_x, map_y), fill)
    valid = (map_x >= -0.5) & (map_x <= w - 0.5) & (map_y >= -0.5) & (map_y <= h - 0.5)
    return out, valid


def fill_holes(image: np.ndarray, valid: np.ndarray, fill: Fill = "nearest") -> np.ndarray:
    """Fill pixels that received no value.

    Cracks -- holes of up to two pixels between valid pixels, found by a 3x3 morphological
    closing of the valid mask, as left by splatting a stretched frame -- are filled by
    averaging their valid neighbours (the paper: "filled by averaging the nearby pixels").
    What remains (the area no scanline reached) is black or a copy of the nearest valid
    pixel.

    Parameters
    ----------
    image : ndarray of shape (h, w[, c]), float
        Image with undefined values where ``valid`` is False.
    valid : ndarray of bool, shape (h, w)
    fill : {'nearest', 'black'}

    Returns
    -------
    ndarray of float32
        A filled copy.
    """
    img = image.astype(np.float32, copy=True)
    ok = valid.copy()
    img[~ok] = 0
    closed = cv2.morphologyEx(ok.astype(np.uint8), cv2.MORPH_CLOSE, np.ones((3, 3), np.uint8),
                              borderType=cv2.BORDER_REPLICATE).astype(bool)
    cracks = closed & ~ok
    kernel = np.ones((3, 3), np.float32)
    while cracks.any():
        wsum = cv2.filter2D(ok.astype(np.float32), -1, kernel, borderType=cv2.BORDER_CONSTANT)
        acc = cv2.filter2D(img, -1, kernel, borderType=cv2.BORDER_CONSTANT)
        fillable = cracks & (wsum > 0)
        if not fillable.any():
            break
        norm = np.maximum(wsum, 1e-9)
        avg = acc / (norm[..., None] if img.ndim == 3 else norm)
        img[fillable] = avg[fillable]
        ok |= fillable
        cracks &= ~fillable
    if (~ok).any():
        if fill == "nearest" and ok.any():
            # Each hole takes the value of its nearest valid pixel.
            _, labels = cv2.distanceTransformWithLabels(
                (~ok).astype(np.uint8), cv2.DIST_L2, 3, labelType=cv2.DIST_LABEL_PIXEL)
            src = np.flatnonzero(ok.ravel())
            lut = np.zeros(int(labels.max()) + 1, dtype=np.int64)
            lut[labels.ravel()[src]] = src
            nearest = lut[labels.ravel()]
            flat = img.reshape(img.shape[0] * img.shape[1], -1)
            holes = ~ok.ravel()
            flat[holes] = flat[nearest[holes]]
            img = flat.reshape(img.shape)
        else:
            img[~ok] = 0
    return img


def splat(image: np.ndarray, displacement: np.ndarray, fill: Fill = "nearest",
          eps: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Forward splatting of eq. 26 with inverse-distance weights (Sec. V.D).

    Parameters
    ----------
    image : ndarray of shape (h, w[, c])
        Frame in top-bottom orientation.
    displacement : ndarray of shape (h, 2)
        Per-scanline ``Delta``; pixel ``s`` goes to ``p = s - Delta(s_y)``.
    fill : {'nearest', 'black'}
        What to put where no pixel lands (after crack filling).
    eps : float
        Added to distances so a pixel landing on a grid point keeps its value.

    Returns
    -------
    out : ndarray like ``image``
    valid : ndarray of bool, shape (h, w)
        True where at least one pixel landed.
    """
    h, w = image.shape[:2]
    img = image.reshape(h, w, -1).astype(np.float64)
    c = img.shape[2]
    py = np.arange(h, dtype=np.float64)[:, None] - displacement[:, 1:2]
    px = np.arange(w, dtype=np.float64)[None, :] - displacement[:, 0:1]
    py = np.broadcast_to(py, (h, w)).ravel()
    px = px.ravel()
    vals = img.reshape(-1, c)
    x0, y0 = np.floor(px), np.floor(py)
    n = h * w
    wsum = np.zeros(n)
    acc = np.zeros((n, c))
    for ox in (0.0, 1.0):
        for oy in (0.0, 1.0):
            gx, gy = x0 + ox, y0 + oy
            inside = (gx >= 0) & (gx < w) & (gy >= 0) & (gy < h)
            wt = 1.0 / (np.hypot(gx - px, gy - py) + eps)
            idx = (gy * w + gx).astype(np.int64)[inside]
            wi = wt[inside]
            wsum += np.bincount(idx, weights=wi, minlength=n)
            for k in range(c):
                acc[:, k] += np.bincount(idx, weights=wi * vals[inside, k], minlength=n)
    valid = (wsum > 0).reshape(h, w)
    out: np.ndarray = (acc / np.maximum(wsum, 1e-300)[:, None]).reshape(h, w, c)
    out = fill_holes(out.astype(np.float32), valid, fill)
    out = out.reshape(image.shape)
    if np.issubdtype(image.dtype, np.integer):
        info = np.iinfo(image.dtype)
        out = np.clip(np.rint(out), info.min, info.max)
    return out.astype(image.dtype), valid


class PictureWarper:
    """Apply one frame's motion to every plane of a picture: the per-frame warp policy.

    A *picture* is a list of planes in coded orientation; the first is the luma (or a
    colour image). Every plane is turned to top-bottom readout, warped by the same
    displacement scaled to its size (4:2:0 chroma included) and turned back. A per-pixel
    motion (``field``) is applied by backward maps (:func:`field_maps`); a per-scanline
    one by :func:`remap_maps` or, with ``warp='splat'``, by the paper's forward
    splatting (:func:`splat`). A stabilisation's :class:`~unjello.trajectory.Reframe` is
    composed with the backward maps (:func:`reframe_maps`): one resampling. With
    ``fill='nearest'`` and a dense motion's neighbour flows, what the frame does not see
    is taken from its neighbours (:mod:`unjello.warp.fill.neighbours`) instead of repeating the
    edge.

    Parameters
    ----------
    timing : SensorTiming
        Its scan direction turns the planes.
    warp : {'remap', 'splat'}
    fill : {'nearest', 'black'}
    undistort : Lens, optional
        A fisheye lens (its focal length in pixels of the first plane) whose curvature is
        then taken out of every corrected plane (:meth:`~unjello.lens.Lens.undistortion_maps`).

    Attributes
    ----------
    unseen : float
        Of the last picture warped, the share of its first plane whose source lies beyond
        the frame's edge and that no neighbour supplied (the edge repeated, or black).
    """

    #: The pictures either side that may fill what a frame did not see: the neighbours, and
    #: those beyond where a neighbour's view carries an object out (``around``'s -REACH..REACH).
    REACH = 2

    def __init__(self, timing: SensorTiming, warp: str = "remap", fill: str = "nearest",
                 undistort: Lens | None = None) -> None:
        self.direction = timing.direction
        self.timing = timing
        self.warp, self.fill = warp, fill
        self.undistort = undistort
        self._buffers: dict[tuple[str, int, int], tuple[np.ndarray, np.ndarray]] = {}
        self._lens_maps: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = {}
        self.unseen = 0.0

    def __call__(self, planes: list[np.ndarray], motion: FrameMotion,
                 around: dict[int, list[np.ndarray] | None] | None = None
                 ) -> list[np.ndarray]:
        """Warp a picture by its frame's motion.

        Parameters
        ----------
        planes : list of ndarray
            The picture, coded orientation.
        motion : FrameMotion
            Its motion (per scanline, or per pixel with ``field``).
        around : dict, optional
            Frame offset (-1, 1; up to :attr:`REACH` away) -> that frame's planes, for
            filling (None where the clip has no such frame).

        Returns
        -------
        list of ndarray
            The corrected planes, same shapes and dtypes.
        """
        d = self.direction
        fill: Fill = "black" if self.fill == "black" else "nearest"
        h, w = to_top_bottom(planes[0], d).shape[:2]
        # 1. A per-pixel motion's backward maps, on its field's grid.
        maps = frame_maps(motion, h, w)[0] if motion.field is not None else None
        # 2. What the frame did not see, from its neighbours (with ``fill='nearest'``).
        fills = (self._neighbour_fill(planes, motion, maps, around, (h, w))
                 if maps is not None and around and fill == "nearest" else None)
        # 3. Each plane warped: per scanline, or through its maps (made band by band), then
        # filled.
        sized: dict[tuple[int, int], tuple[np.ndarray, np.ndarray] | PlaneMaps] = {}
        out = []
        for i, plane in enumerate(planes):
            tb = to_top_bottom(plane, d)
            ph, pw = tb.shape[:2]
            scale = plane.shape[1] / planes[0].shape[1]  # chroma: the lens in its pixels
            if maps is None and (self.warp == "splat" or (
                    self.undistort is None and motion.reframe.identity)):  # per scanline
                if i == 0:
                    self.unseen = _unseen_rows(motion.displacement, w)
                res = self._per_scanline(tb, motion, (h, w), scale, fill)
            else:
                if (ph, pw) not in sized:  # U and V share their maps
                    sized[(ph, pw)] = self._plane_maps(maps, motion, ph, pw, (h, w), scale)
                plane_maps = sized[(ph, pw)]
                if isinstance(plane_maps, PlaneMaps):
                    res = warp_bands(tb, plane_maps, fill,
                                     self._buffer("band", band_rows(ph, pw), pw))
                else:
                    res = apply_maps(tb, plane_maps, fill=fill)
                if fills is not None:
                    res = fills(i, res, plane_maps, edge_slopes(
                        _plane_displacement(motion, ph, pw, h, w, camera=True)))
                if i == 0:
                    self.unseen = fills.unseen if fills is not None else outside_share(
                        plane_maps)
            out.append(from_top_bottom(res, d))
        return out

    def _neighbour_fill(self, planes: list[np.ndarray], motion: FrameMotion,
                        maps: tuple[np.ndarray, np.ndarray],
                        around: dict[int, list[np.ndarray] | None],
                        frame: tuple[int, int]) -> NeighbourFill | None:
        """Return the fill from the neighbours the motion has flows to and ``around`` holds."""
        d, (h, w) = self.direction, frame
        have = [(k, pic, flow) for k, flow in motion.neighbours
                if (pic := around.get(k)) is not None]
        if not have:
            return None
        # The background nearer objects uncovered too, where nothing is composed.
        plain = self.undistort is None and motion.reframe.identity
        return NeighbourFill(
            maps, [([to_top_bottom(p, d) for p in pic], flow) for _, pic, flow in have],
            [k for k, _, _ in have], self.timing,
            grid_field(motion.field, maps[0].shape, (h, w))
            if plain and motion.field is not None else None,
            own=[to_top_bottom(p, d) for p in planes],
            lone=bool(motion.front),
            shown=shown_objects(motion.front, maps[0].shape, (h, w)),
            further=[None if (f := around.get(2 * k)) is None else
                     [to_top_bottom(p, d) for p in f] for k, _, _ in have])

    def _per_scanline(self, tb: np.ndarray, motion: FrameMotion, frame: tuple[int, int],
                      scale: float, fill: Fill) -> np.ndarray:
        """Return a top-bottom plane warped by a per-scanline motion, without maps."""
        ph, pw = tb.shape[:2]
        if self.warp == "splat":
            res, _ = splat(tb, _plane_displacement(motion, ph, pw, *frame), fill=fill)
            if self.undistort is not None:  # a forward splat: a second resampling
                res = apply_maps(res, self._lens(ph, pw, scale))
            return res
        return shift_planes(tb, _plane_displacement(motion, ph, pw, *frame), fill)

    def _plane_maps(self, maps: tuple[np.ndarray, np.ndarray] | None, motion: FrameMotion,
                    ph: int, pw: int, frame: tuple[int, int], scale: float
                    ) -> tuple[np.ndarray, np.ndarray] | PlaneMaps:
        """Return the backward maps of a top-bottom plane of ``ph x pw``.

        A per-pixel motion's (``maps``, on its field's grid) as :class:`PlaneMaps`, made
        band by band as the plane is warped; whole where a lens is composed with them,
        or for a per-scanline motion composed with a reframe or a lens.
        """
        if maps is not None and self.undistort is None:
            return PlaneMaps(*maps, ph, pw)
        buffers = self._buffer("whole", ph, pw)  # reused: not faulted in every frame
        whole = (PlaneMaps(*maps, ph, pw).whole(buffers) if maps is not None else
                 reframe_maps(remap_maps(_plane_displacement(motion, ph, pw, *frame), pw,
                                         out=buffers), motion.reframe, frame))
        if self.undistort is not None:  # one resampling: the maps composed
            whole = compose_maps(whole, self._lens(ph, pw, scale))
        return whole

    def _lens(self, ph: int, pw: int, scale: float) -> tuple[np.ndarray, np.ndarray]:
        """Return the lens's undistortion maps for a top-bottom plane of ``ph x pw``.

        The fisheye model is radial about the centre, so it reads the same in every
        orientation of the picture; ``scale`` is the plane's pixels per first-plane pixel.
        """
        assert self.undistort is not None
        if (ph, pw) not in self._lens_maps:
            self._lens_maps[(ph, pw)] = self.undistort.scaled(scale).undistortion_maps((ph, pw))
        return self._lens_maps[(ph, pw)]

    def _buffer(self, use: str, h: int, w: int) -> tuple[np.ndarray, np.ndarray]:
        """Two float32 maps of ``h x w`` for one ``use`` (a band, the whole), reused."""
        if (use, h, w) not in self._buffers:
            self._buffers[(use, h, w)] = (np.empty((h, w), np.float32),
                                          np.empty((h, w), np.float32))
        return self._buffers[(use, h, w)]


def _unseen_rows(displacement: np.ndarray, w: int) -> float:
    """Share of a per-scanline warp's output whose source lies beyond the frame's edge."""
    dx, sy = row_sources(displacement)
    h = len(sy)
    cols = np.where((sy < -0.5) | (sy > h - 0.5), w, np.minimum(w, np.floor(np.abs(dx) + 0.5)))
    return float(cols.sum()) / (h * w)


def _plane_displacement(motion: FrameMotion, ph: int, pw: int, h: int, w: int,
                        camera: bool = False) -> np.ndarray:
    """Return the per-scanline displacement for a plane of ``ph x pw`` (4:2:0 chroma).

    With ``camera``, the camera's own (:attr:`FrameMotion.camera`) where it has one.
    """
    d = motion.camera if camera and motion.camera is not None else motion.displacement
    if (ph, pw) == (h, w):
        return d
    return resample_displacement(d, ph, pw / w, ph / h)
