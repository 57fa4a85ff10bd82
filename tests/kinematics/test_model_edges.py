"""Edges of the kinematic models that mutation testing found unpinned (docs/testing.md).

The radius-of-curvature model where its curvature law divides by zero, and
the ICR model's default slip factor (1 = none) in the Jacobian.
"""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.kinematics.models import twist_icr, twist_icr_jacobian, twist_roc


def test_roc_where_the_curvature_law_divides_by_zero_gives_a_nan_yaw_rate():
    # one track still: lambda = |v_r + v_l| / |v_r - v_l| = 1, so with beta_2 = -1
    # the denominator 1 + beta_2 sqrt(lambda) is exactly 0: no y_0, an invalid set
    v_x, v_y, omega = twist_roc([0.0, 1.0, 0.0], [1.0, 1.0, 2.0], 0.8, 0.5, -1.0, 0.6)
    assert np.isnan(omega[0]) and omega[1] == 0.0  # straight: no yaw rate whatever y_0
    # v_l = 0, v_r = 2: lambda = 1 again, the same zero denominator
    assert np.isnan(omega[2])
    np.testing.assert_allclose(v_x, 0.8 * 0.5 * np.array([1.0, 2.0, 2.0]))
    assert v_x.dtype == omega.dtype == np.float64 and np.all(v_y == 0.0)


def test_roc_with_a_nonzero_denominator_is_the_edd_with_its_half_width():
    v_l, v_r, alpha, beta_1, beta_2, b = 0.2, 1.0, 0.9, 0.5, 2.0, 0.6
    lam = abs(v_r + v_l) / abs(v_r - v_l)
    y_0 = 0.5 * b * (1.0 + beta_1 / (1.0 + beta_2 * np.sqrt(lam)))
    _, _, omega = twist_roc(v_l, v_r, alpha, beta_1, beta_2, b)
    assert omega == np.float64(alpha * (v_r - v_l) / (2.0 * y_0))


def test_icr_jacobian_default_alpha_is_no_slip():
    args = (np.array([0.3, -0.5]), np.array([0.9, 0.4]), 0.35, -0.3, 0.1)
    np.testing.assert_array_equal(twist_icr_jacobian(*args), twist_icr_jacobian(*args, 1.0))
    # and it is the derivative of the model at alpha = 1: d v_x / d alpha = v_x(alpha=1)
    v_x, _, omega = twist_icr(*args)
    jac = twist_icr_jacobian(*args)
    np.testing.assert_allclose(jac[..., 0, 3], v_x, rtol=1e-12)
    np.testing.assert_allclose(jac[..., 2, 3], omega, rtol=1e-12)


def test_icr_spacing_error_names_the_first_three_of_each_coordinate():
    y_l = np.array([0.1, 0.2, 0.3, 0.4, -1.0])  # the last pair is the wrong way round
    y_r = np.array([-0.1, -0.2, -0.3, -0.4, 0.0])
    with pytest.raises(ValueError, match="y_l > y_r") as error:
        twist_icr(1.0, 1.0, y_l, y_r, 0.0)
    message = str(error.value)
    assert "y_l=[0.1 0.2 0.3], y_r=[-0.1 -0.2 -0.3]" in message and "0.4" not in message
