import numpy as np

from unjello.warp.front_layers import shown_objects


def _layer(dx: float) -> np.ndarray:
    """A 20 x 30 layer: weight 1 on columns 10-14 of the frame, every pixel's source dx on."""
    layer = np.zeros((20, 30, 3), np.float32)
    layer[..., 0] = dx
    layer[:, 10:15, 2] = 1.0
    return layer


def test_an_object_is_shown_where_the_layer_takes_its_pixels():
    assert shown_objects((), (20, 30)) is None
    shown = shown_objects((_layer(0.0),), (20, 30))
    assert shown is not None
    assert np.array_equal(np.flatnonzero(shown[5]), np.arange(10, 15))
    # Each output pixel shows its source 3 px on: the object shows 3 px before its pixels.
    moved = shown_objects((_layer(3.0),), (20, 30))
    assert moved is not None
    assert np.array_equal(np.flatnonzero(moved[5]), np.arange(7, 12))


def test_objects_shown_are_put_on_the_maps_grid_and_together():
    other = _layer(0.0)
    other[..., 2] = 0.0
    other[:, 20:25, 2] = 1.0
    shown = shown_objects((_layer(0.0), other), (10, 15))
    assert shown is not None and shown.shape == (10, 15)
    assert shown[:, 5:7].all() and shown[:, 10:12].all()
    assert not shown[:, :4].any() and not shown[:, 13:].any()


def test_a_layers_displacement_is_in_the_frames_pixels():
    # The frame twice the layer's grid: 6 frame px are 3 of the grid.
    assert np.array_equal(shown_objects((_layer(6.0),), (20, 30), (40, 60)),
                          shown_objects((_layer(3.0),), (20, 30)))
