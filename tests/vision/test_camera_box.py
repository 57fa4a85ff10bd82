"""The region of interest's pixel box in Python floats: the numpy formulation's boxes exactly."""

from __future__ import annotations

import numpy as np

from terrain_odom.vision.camera import _pixel_box


def _numpy_box(uv: np.ndarray, width: int, height: int) -> tuple[int, int, int, int]:
    """Return the box as numpy computes it: floor(min + 0.5), ceil(max + 0.5), clipped."""
    lo = np.floor(uv.min(axis=0) + 0.5).astype(int)
    hi = np.ceil(uv.max(axis=0) + 0.5).astype(int)
    x0, x1 = np.clip([lo[0], hi[0]], 0, width)
    y0, y1 = np.clip([lo[1], hi[1]], 0, height)
    return int(x0), int(y0), int(x1), int(y1)


def test_the_box_is_the_numpy_formulations_on_random_halves_edges_and_outside_points():
    rng = np.random.default_rng(7)
    for k in range(20_000):
        uv = rng.normal(300.0, 400.0, (int(rng.integers(1, 9)), 2))
        if k % 3 == 0:
            uv = np.round(uv * 2.0) / 2.0  # pixel edges and centres exactly
        assert _pixel_box(uv, 640, 480) == _numpy_box(uv, 640, 480)


def test_the_box_covers_every_pixel_a_point_touches():
    assert _pixel_box(np.array([[0.0, 0.0]]), 640, 480) == (0, 0, 1, 1)  # pixel (0, 0)'s centre
    assert _pixel_box(np.array([[-0.5, 9.5], [2.49, 10.0]]), 640, 480) == (0, 10, 3, 11)
    assert _pixel_box(np.array([[-50.0, -5.0], [700.0, 900.0]]), 640, 480) == (0, 0, 640, 480)
