"""The warp straight from coarse maps against its reference: resize_maps + apply_maps."""

import numpy as np
import pytest

from unjello.band_remap import coarse_at, remap_coarse, remap_scanlines
from unjello.timing import pixel_grid
from unjello.warp import apply_maps, remap_maps, resize_maps, scanline_sources


def _maps(gh: int, gw: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A smooth backward map with a source outside the frame along every side."""
    gx, gy = pixel_grid(gh, gw)
    rng = np.random.default_rng(seed)
    wave = rng.uniform(1, 4)
    mx = gx + 3 + wave * np.sin(gy / 7 + gx / 11)
    my = gy - 2 + wave * np.cos(gx / 9)
    return mx.astype(np.float32), my.astype(np.float32)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32])
@pytest.mark.parametrize("fill", ["nearest", "black"])
@pytest.mark.parametrize("size", [(120, 200), (60, 100), (30, 50), (17, 23)])
def test_remap_coarse_matches_its_reference(dtype: type, fill: str, size: tuple) -> None:
    # Upsampled 4x and 2x (luma, 4:2:0 chroma), the grid's own size and a smaller plane.
    rng = np.random.default_rng(3)
    top = 255 if dtype == np.uint8 else 1023
    img = rng.uniform(0, top, size).astype(dtype)
    maps = _maps(30, 50)
    ref = apply_maps(img, resize_maps(*maps, *size), fill=fill)
    got = remap_coarse(img, maps, fill=fill)
    assert got.dtype == img.dtype and got.shape == img.shape
    diff = np.abs(got.astype(np.float64) - ref)
    # The same maps, sampled by the same cv2.remap: a rare last-bit difference in a map
    # can move a sample by one of OpenCV's 1/32-px steps.
    assert diff.mean() < 1e-3 * top
    assert diff.max() <= (1 if dtype != np.float32 else 0.05 * top)


def test_remap_coarse_colour_image() -> None:
    rng = np.random.default_rng(4)
    img = rng.integers(0, 255, (64, 96, 3)).astype(np.uint8)
    maps = _maps(16, 24, seed=1)
    ref = apply_maps(img, resize_maps(*maps, 64, 96))
    assert np.abs(remap_coarse(img, maps).astype(int) - ref).max() <= 1


def test_coarse_at_is_the_upsampled_map_at_those_pixels() -> None:
    maps = _maps(27, 48, seed=2)
    full = resize_maps(*maps, 108, 192)
    rng = np.random.default_rng(5)
    ys, xs = rng.integers(0, 108, 500), rng.integers(0, 192, 500)
    ys[:4], xs[:4] = (0, 107, 0, 107), (0, 191, 191, 0)  # the corners: held edges
    px, py = coarse_at(maps, (108, 192), ys, xs)
    assert np.abs(px - full[0][ys, xs]).max() < 1e-3
    assert np.abs(py - full[1][ys, xs]).max() < 1e-3


@pytest.mark.parametrize("fill", ["nearest", "black"])
def test_remap_scanlines_is_remap_maps_band_by_band(fill: str) -> None:
    # A per-scanline shear and stretch with rows read from outside the frame at the ends.
    rng = np.random.default_rng(6)
    img = rng.integers(0, 255, (130, 90)).astype(np.uint8)
    rows = np.arange(130)
    disp = np.stack([6 * np.sin(rows / 17), 0.08 * rows - 4], axis=1)
    ref = apply_maps(img, remap_maps(disp, 90), fill=fill)
    assert np.array_equal(remap_scanlines(img, *scanline_sources(disp), fill=fill), ref)
