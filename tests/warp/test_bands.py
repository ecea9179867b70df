"""Maps made band by band: against cv2.resize and cv2.remap of the whole maps."""

import cv2
import numpy as np
import pytest

from unjello._kernels.field import map_rows, outside_in_rows
from unjello.warp import bands as map_bands
from unjello.warp.bands import PlaneMaps, warp_bands


def coarse_maps(h: int, w: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A smooth backward map on an (h, w) grid, leaving the frame at the right."""
    rng = np.random.default_rng(seed)
    gy, gx = np.mgrid[0:h, 0:w].astype(np.float32)
    mx = gx + 2 * np.sin(gy / 5) + 0.2 * w * (gx > 0.8 * w) + rng.normal(0, 0.3, (h, w))
    my = gy + 1.5 * np.cos(gx / 7) + rng.normal(0, 0.3, (h, w))
    return mx.astype(np.float32), my.astype(np.float32)


def resized(mx: np.ndarray, my: np.ndarray, height: int, width: int
            ) -> tuple[np.ndarray, np.ndarray]:
    """The reference: cv2.resize of the whole maps, the displacement held at the edges."""
    h, w = mx.shape
    out = []
    for m, n, size, scale, axis in ((mx, w, width, width / w, 1), (my, h, height, height / h, 0)):
        big = cv2.resize((m + 0.5) * np.float32(scale) - 0.5, (width, height),
                         interpolation=cv2.INTER_LINEAR).astype(np.float64)
        coarse = (np.arange(size) + 0.5) / scale - 0.5
        beyond = (coarse - np.clip(coarse, 0, n - 1)) * scale
        big += beyond[None, :] if axis == 1 else beyond[:, None]
        out.append(big)
    return out[0], out[1]


@pytest.mark.parametrize("coarse, plane", [((27, 48), (108, 192)), ((27, 48), (54, 96)),
                                           ((17, 29), (61, 100)), ((1, 12), (4, 48)),
                                           ((9, 1), (36, 3)), ((20, 30), (20, 30))])
def test_plane_maps_are_the_resized_maps(coarse, plane):
    mx, my = coarse_maps(*coarse)
    want = resized(mx, my, *plane)
    got = PlaneMaps(mx, my, *plane).whole()
    for g, r in zip(got, want, strict=True):
        assert g.dtype == np.float32 and g.shape == plane
        assert np.abs(g - r).max() < 1e-3


def test_map_rows_is_its_numpy_formula():
    rng = np.random.default_rng(1)
    rows = rng.normal(0, 50, (12, 37)).astype(np.float32)
    top = rng.integers(0, 11, 40)
    frac = rng.random(40).astype(np.float32)
    held = rng.normal(0, 2, 40).astype(np.float32)
    out = np.empty((25, 37), np.float32)
    map_rows(rows, top, frac, held, 10, 35, out)
    f = frac[10:35, None]
    want = (np.float32(1) - f) * rows[top[10:35]] + f * rows[top[10:35] + 1] + held[10:35, None]
    assert np.array_equal(out, want)


@pytest.mark.parametrize("plane", [(90, 160), (45, 80), (67, 123)])
def test_outside_in_rows_lists_what_the_whole_maps_show(plane):
    """The reference: the marked cells upsampled (nearest), their pixels listed, those
    whose source (the whole maps) is outside kept."""
    h, w = plane
    maps = PlaneMaps(*coarse_maps(9, 16, seed=6), h, w)
    mx, my = maps.whole()
    cells = (np.random.default_rng(6).random((9, 16)) < 0.4).astype(np.uint8)
    big = cv2.resize(cells, (w, h), interpolation=cv2.INTER_NEAREST)
    pts = cv2.findNonZero(big).reshape(-1, 2)
    xs, ys = pts[:, 0], pts[:, 1]
    sx, sy = mx[ys, xs], my[ys, xs]
    out = (sx < -0.5) | (sx > w - 0.5) | (sy < -0.5) | (sy > h - 0.5)
    got = maps.outside(cells)
    for a, b in zip(got, (xs[out], ys[out], sx[out], sy[out]), strict=True):
        assert np.array_equal(a, b)
    assert out.sum() > 20
    assert len(outside_in_rows(np.zeros_like(cells), *maps._rows, maps._top, maps._frac,
                               maps._held_y)[0]) == 0


def test_sample_takes_the_whole_maps_every_step():
    maps = PlaneMaps(*coarse_maps(27, 48), 108, 192)
    whole = maps.whole()
    for got, m in zip(maps.sample(8), whole, strict=True):
        assert np.array_equal(got, m[4::8, 4::8])


@pytest.mark.parametrize("dtype, channels", [(np.uint8, 0), (np.uint8, 3), (np.uint16, 0),
                                             (np.float32, 0)])
@pytest.mark.parametrize("fill", ["nearest", "black"])
def test_warp_bands_is_the_whole_remap(monkeypatch, dtype, channels, fill):
    monkeypatch.setattr(map_bands, "BAND_SAMPLES", 7 * 150)  # 7 rows a band: 22 bands
    h, w = 150, 150
    rng = np.random.default_rng(3)
    shape = (h, w, channels) if channels else (h, w)
    image = cv2.GaussianBlur((rng.random(shape) * 60000 if dtype == np.uint16 else
                              rng.random(shape) * 255).astype(dtype), (0, 0), 2)
    maps = PlaneMaps(*coarse_maps(30, 30), h, w)
    border = cv2.BORDER_REPLICATE if fill == "nearest" else cv2.BORDER_CONSTANT
    want = cv2.remap(image, *maps.whole(), cv2.INTER_LINEAR, borderMode=border, borderValue=0)
    got = warp_bands(image, maps, fill)
    assert got.dtype == image.dtype and got.shape == image.shape
    assert np.array_equal(got, want)
    # Buffers given (larger than a band) are used as they are.
    buffers = (np.empty((9, w), np.float32), np.empty((9, w), np.float32))
    assert np.array_equal(warp_bands(image, maps, fill, buffers), want)
