"""The box-counting fit's slope weights against numpy's least-squares line.

``sfta._slope_weights`` builds the table the module keeps at import; the
tests call it directly, so a change to it is seen here and not only through
the table computed before any test ran.
"""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.vision import sfta


@pytest.mark.parametrize("max_sizes", [2, 5, 12])
def test_each_row_is_the_least_squares_slope_over_its_first_sizes(max_sizes):
    weights = sfta._slope_weights(max_sizes)
    assert weights.shape == (max_sizes + 1, max_sizes)
    rng = np.random.default_rng(max_sizes)
    y = rng.normal(size=max_sizes) * 3.0
    for n in range(2, max_sizes + 1):
        log_inverse_size = -np.log(2.0) * np.arange(n)  # log(1 / s), s = 1, 2, 4, ...
        slope = np.polyfit(log_inverse_size, y[:n], 1)[0]
        assert weights[n] @ y == pytest.approx(slope, rel=1e-12, abs=1e-12)
        assert not weights[n, n:].any()  # sizes from the n-th on are not fitted


def test_rows_of_no_or_one_size_fit_the_first_two_sizes():
    weights = sfta._slope_weights(6)
    np.testing.assert_array_equal(weights[0], weights[2])
    np.testing.assert_array_equal(weights[1], weights[2])
    # N(1) = 4, N(2) = 1: log N falls by log 4 as log(1/s) falls by log 2, slope 2
    assert weights[0] @ np.log([4.0, 1.0, 1.0, 1.0, 1.0, 1.0]) == pytest.approx(2.0, rel=1e-12)


def test_the_module_table_is_the_function_of_64_sizes():
    np.testing.assert_array_equal(sfta._SLOPE_WEIGHTS, sfta._slope_weights(64))
