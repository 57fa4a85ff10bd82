"""The arc coefficients equal, bit for bit, their former formulation (both branches everywhere)."""

from __future__ import annotations

import numpy as np
import pytest

from bench.fit import former_arc_coefficients
from terrain_odom.kinematics.integration import _SERIES_LIMIT, _arc_coefficients

_former = former_arc_coefficients  # the speed baseline of bench/fit.py


ANGLES = [
    np.concatenate(
        [
            np.random.default_rng(0).normal(scale=0.02, size=4993),  # both branches
            [0.0, -0.0, _SERIES_LIMIT, -_SERIES_LIMIT, np.nextafter(_SERIES_LIMIT, 0), 3.0, -7.0],
        ]
    ).reshape(50, 100),
    np.array(0.3),  # a 0-d angle stays 0-d
    np.array(1e-5),
    np.full(4, 0.5),  # no small angle
    np.full(3, 1e-4),  # only small ones
    np.empty(0),
]


@pytest.mark.parametrize("phi", ANGLES, ids=lambda a: f"shape{a.shape}")
def test_arc_coefficients_are_bit_identical_to_the_former_formulation(phi: np.ndarray) -> None:
    got, expected = _arc_coefficients(phi), _former(phi)
    for value, reference in zip(got, expected, strict=True):
        assert value.shape == reference.shape
        assert value.tobytes() == reference.tobytes()
    assert all(
        v.tobytes() == r.tobytes()
        for v, r in zip(_arc_coefficients(phi, derivatives=False), expected[:2], strict=True)
    )
