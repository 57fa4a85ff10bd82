"""Robust and circular statistics against values worked out by hand (written for mutation survivors)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.evaluation.robust import MAD_TO_STD, circular_median, correlation_time


def test_mad_to_std_is_the_normal_ratio():
    # 1 / Phi^-1(3/4) = 1.482602...
    assert MAD_TO_STD == pytest.approx(1.0 / 0.6744897501960817, abs=1e-4)


def test_weighted_circular_median_by_hand():
    # equal weights, an even count: the lower of the two middle angles
    assert circular_median(np.array([0.1, 0.2, 0.3, 0.4])) == pytest.approx(0.2, abs=1e-12)
    # a heavy angle is the median
    assert circular_median(np.array([0.1, 0.2, 0.3]), np.array([1.0, 1.0, 5.0])) == pytest.approx(
        0.3, abs=1e-12
    )
    # across +-pi, weighted towards -3.0 rad
    got = circular_median(np.array([3.0, -3.0, 2.9]), np.array([1.0, 3.0, 1.0]))
    assert got == pytest.approx(-3.0, abs=1e-12)


@pytest.mark.parametrize("centre", [1.5, -1.5, np.pi, 0.0])
def test_a_cluster_is_never_split_by_the_wrap_wherever_it_lies(centre):
    """Unwrapped around the cluster's own circular mean, not around any other angle."""
    spread = np.array([-0.2, -0.1, 0.0, 0.1, 0.25])
    angles = np.angle(np.exp(1j * (centre + spread)))
    got = circular_median(angles[::-1])
    assert np.angle(np.exp(1j * (got - centre))) == pytest.approx(0.0, abs=1e-12)


def test_correlation_time_by_hand():
    # centred -1.5, -0.5, 0.5, 1.5: variance sum 5, lag 1 sum 1.25: 1 + 2 * 0.25
    assert correlation_time(np.array([1.0, 2.0, 3.0, 4.0])) == pytest.approx(1.5, abs=1e-12)
    # a ramp of 6: lag 1 8.75 / 17.5, lag 2 1 / 17.5, lag 3 negative (not reached: lags < n / 2)
    assert correlation_time(np.arange(6.0)) == pytest.approx(1 + 2 * (0.5 + 1 / 17.5), abs=1e-12)


def test_correlation_time_of_short_constant_and_uncorrelated_sequences_is_one():
    assert correlation_time(np.array([1.0, 2.0, 3.0])) == 1.0  # fewer than 4
    assert correlation_time(np.full(6, 2.0)) == 1.0  # no variance
    # the sum stops at the first lag whose correlation is not positive (here exactly 0),
    # though lag 2 is positive again
    x = np.array([-1.0, 0.0, -1.0, 0.0, 0.0, 1.0, 0.0, 1.0])
    assert x[:-1] @ x[1:] == 0.0 and x[:-2] @ x[2:] > 0.0
    assert correlation_time(x) == 1.0
