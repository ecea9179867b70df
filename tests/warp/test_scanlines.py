"""The per-scanline warp without maps against cv2.remap with the row maps."""

import numpy as np
import pytest

from unjello.warp.maps import remap_maps
from unjello.warp.scanlines import shift_planes
from unjello.warp.warper import apply_maps


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32])
@pytest.mark.parametrize("fill", ["nearest", "black"])
def test_shift_planes_is_remap_with_row_maps(dtype, fill):
    """The reference: :func:`cv2.remap` with :func:`remap_maps` (1/32-px weights: one level)."""
    rng = np.random.default_rng(9)
    h, w = 61, 83
    top = 255 if dtype == np.uint8 else 1023
    image = (rng.random((h, w, 3)) * top).astype(dtype)
    rows = np.arange(h)
    disp = np.stack([12 * np.sin(rows / 9) + 3.3, 0.3 * rows - 9.7], 1)  # past every edge
    disp[20:24, 0] = (w + 5, -w - 5, 0.5, -0.25)  # whole rows from beyond the sides
    for img in (image, np.ascontiguousarray(image[..., 1])):
        want = apply_maps(img, remap_maps(disp, w), fill).astype(float)
        got = shift_planes(img, disp, fill)
        assert got.dtype == img.dtype and got.shape == img.shape
        assert np.abs(got.astype(float) - want).max() <= (1.0 if dtype != np.float32 else
                                                          top / 32.0)
