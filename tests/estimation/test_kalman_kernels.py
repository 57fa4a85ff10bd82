"""The Kalman arithmetic both EKFs' kernels share, against numpy's and known answers.

The filters' tests hold these to the filterpy reference through whole runs,
where a covariance is always symmetric positive definite: a pivot the
inverse never needs, a negative variance ``std_into`` never meets and
an angle exactly at -pi stay untested there (mutation testing,
docs/testing.md). Each function here gets inputs that reach its guards.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from terrain_odom.estimation import _kalman_kernels as kalman
from terrain_odom.kinematics import wrap_angle


@pytest.mark.parametrize(
    ("angle", "expected"),
    [
        (math.pi, math.pi),
        (-math.pi, math.pi),  # the interval is (-pi, pi]
        (3.0 * math.pi, math.pi),
        (-3.0 * math.pi, math.pi),
        (math.pi + 0.25, -math.pi + 0.25),
        (-math.pi - 0.25, math.pi - 0.25),
        (0.3, 0.3),
        (-3.1, -3.1),
    ],
)
def test_wrap_known_answers(angle, expected):
    assert kalman.wrap(angle) == pytest.approx(expected, abs=1e-15)
    assert -math.pi < kalman.wrap(angle) <= math.pi


def test_wrap_equals_wrap_angle_and_keeps_angles_inside_bit_for_bit():
    angles = np.r_[np.linspace(-20.0, 20.0, 801), np.nextafter(-math.pi, 0.0), -math.pi]
    for angle in angles:
        assert kalman.wrap(angle) == pytest.approx(wrap_angle(angle), abs=1e-15)
        if -math.pi < angle <= math.pi:
            assert kalman.wrap(angle) == angle


def _matrices():
    rng = np.random.default_rng(1)
    yield np.array([[0.0, 1.0], [1.0, 0.0]])  # a zero pivot: needs the row swap
    yield np.array([[1e-13, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 2.0, 3.0]])  # a tiny pivot
    yield np.array([[2.0, 1.0, 0.0], [4.0, 1.0, 1.0], [0.0, 1.0, 5.0]])  # the larger lower
    yield rng.permutation(np.eye(4)) * np.array([1.0, 2.0, 3.0, 4.0])
    for n in (1, 3, 7):
        yield rng.normal(size=(n, n)) + 3.0 * np.eye(n)


@pytest.mark.parametrize("s", list(_matrices()))
def test_inverse_of_matrices_that_need_pivoting(s):
    before = s.copy()
    inv = kalman.inverse(s)
    np.testing.assert_allclose(inv @ s, np.eye(s.shape[0]), rtol=0, atol=1e-12)
    np.testing.assert_allclose(inv, np.linalg.inv(s), rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(s, before)  # the input is left as it was


def test_matmul_equals_numpy_with_zeros_and_ones_in_a():
    rng = np.random.default_rng(2)
    a = rng.normal(size=(5, 5))
    a[a < 0.0] = 0.0
    a[0, 0] = a[2, 3] = 1.0
    b = rng.normal(size=(5, 5))
    np.testing.assert_allclose(kalman.matmul(a, b), a @ b, rtol=1e-14, atol=1e-15)


def test_symmetrise_is_the_mean_of_p_and_its_transpose():
    rng = np.random.default_rng(3)
    p = rng.normal(size=(6, 6))
    expected = 0.5 * (p + p.T)
    kalman.symmetrise(p)
    np.testing.assert_array_equal(p, expected)


def test_std_into_clips_negative_variances_to_zero():
    p = np.diag([4.0, -1e-3, 0.0, 2.25])
    p[0, 1] = p[1, 0] = -7.0  # off the diagonal: not read
    out = np.full(4, np.nan)
    kalman.std_into(p, out)
    assert out.tolist() == [2.0, 0.0, 0.0, 1.5]


def _kalman_problem(rows):
    rng = np.random.default_rng(4)
    a = rng.normal(size=(5, 5))
    p = a @ a.T + np.eye(5)
    jac = rng.normal(size=(len(rows), 5))
    jac[:, 1], jac[0, 0] = 0.0, 1.0  # zeros and ones, as the ICR EKF's H has (sparse terms skipped)
    b = rng.normal(size=(3, 3))
    r = b @ b.T + np.eye(3)  # full, so that the rows picked matter
    return p, jac, np.array(rows), r


@pytest.mark.parametrize("rows", [[0, 1, 2], [0, 2], [2], [1]])
def test_gain_and_joseph_update_equal_their_matrix_formulas(rows):
    p, jac, rows, r = _kalman_problem(rows)
    r_rows = r[np.ix_(rows, rows)]
    s = jac @ p @ jac.T + r_rows
    pht, got_s = kalman.innovation_covariance(p, jac, rows, r)
    np.testing.assert_allclose(pht, p @ jac.T, rtol=1e-13)
    np.testing.assert_allclose(got_s, s, rtol=1e-13)
    gain, si = kalman.kalman_gain(p, jac, rows, r)
    np.testing.assert_allclose(si, np.linalg.inv(s), rtol=1e-12)
    np.testing.assert_allclose(gain, p @ jac.T @ np.linalg.inv(s), rtol=1e-12, atol=1e-14)
    i_kh = np.eye(5) - gain @ jac
    expected = i_kh @ p @ i_kh.T + gain @ r_rows @ gain.T
    kalman.joseph(p, gain, jac, rows, r)
    np.testing.assert_allclose(p, expected, rtol=1e-12, atol=1e-14)
