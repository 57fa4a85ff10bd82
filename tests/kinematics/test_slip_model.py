"""``SlipModel`` (the 2016 slip model): feature switches, shapes, and the slip factor's default.

Written for mutants of ``kinematics/slip.py`` no test killed (docs/testing.md):
a switched-off feature divided instead of multiplied by its switch, the
Jacobian's batch shape taken from only some of its inputs, and ``alpha``
without the features' shape when it is not estimated.
"""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.config import IcrLimits
from terrain_odom.kinematics.slip import SlipModel

B = 2.0
EPS = 1e-3


def _model(lateral_acceleration: bool = True, curvature: bool = True) -> SlipModel:
    return SlipModel(B, EPS, lateral_acceleration, curvature, IcrLimits())


def test_features_known_answers_and_switched_off_features_are_exactly_zero():
    # v_l = 1, v_r = 3: v = 2, omega_0 = (3 - 1) / 2 = 1, a = 2; k = 2 / (4 + eps)
    a, k = _model().features(1.0, 3.0)
    assert a == pytest.approx(2.0, abs=1e-15) and k == pytest.approx(2.0 / (4.0 + EPS), abs=1e-15)
    a_off, k_on = _model(lateral_acceleration=False).features(1.0, 3.0)
    assert a_off == 0.0 and k_on == pytest.approx(k, abs=1e-15)
    a_on, k_off = _model(curvature=False).features(1.0, 3.0)
    assert k_off == 0.0 and a_on == pytest.approx(a, abs=1e-15)
    # off means 0 for any speeds (no division by the switch: no inf, no NaN)
    a_none, k_none = _model(False, False).features([0.5, -1.0, 2.0], [0.5, 1.0, -3.0])
    assert a_none.tolist() == [0.0, 0.0, 0.0] and k_none.tolist() == [0.0, 0.0, 0.0]


def _row(params: np.ndarray, a: float, k: float) -> tuple[float, float, float]:
    """Unclipped ICRs of one row, written out from the model's equations."""
    l1, l2, l3, l4, l5, l6 = params[:6]
    return B / 2 + l1 * a + l2 * k, -(B / 2 + l3 * a + l4 * k), l5 * a + l6 * k


def test_a_batch_of_parameter_rows_against_scalar_features():
    rng = np.random.default_rng(3)
    params = rng.uniform(-0.05, 0.05, (5, 6))
    (y_l, y_r, x_icr, alpha), jac = _model().icrs_with_jacobian(params, 0.7, 0.3)
    assert jac.shape == (5, 4, 6) and y_l.shape == (5,) and alpha == 1.0
    for i in range(5):
        assert (y_l[i], y_r[i], x_icr[i]) == pytest.approx(_row(params[i], 0.7, 0.3), abs=1e-15)
        assert jac[i, 0, :2].tolist() == [0.7, 0.3] and jac[i, 1, 2:4].tolist() == [-0.7, -0.3]
        assert jac[i, 2, 4:].tolist() == [0.7, 0.3]


def test_one_parameter_row_against_features_of_different_shapes():
    params = np.array([0.01, -0.02, 0.03, 0.04, -0.05, 0.06])
    a = np.array([0.0, 0.5, 1.0, 1.5])
    for k in (0.25, np.full(4, 0.25)):  # a batch of a against a scalar k, and both batches
        (y_l, y_r, x_icr, alpha), jac = _model().icrs_with_jacobian(params, a, k)
        assert jac.shape == (4, 4, 6) and alpha.shape == (4,)
        assert jac[:, 0, 0].tolist() == a.tolist() and jac[:, 0, 1].tolist() == [0.25] * 4
        for i in range(4):
            assert (y_l[i], y_r[i], x_icr[i]) == pytest.approx(_row(params, a[i], 0.25), abs=1e-15)
    (_, _, _, alpha), jac = _model().icrs_with_jacobian(params, 0.5, a)  # k the batch
    assert jac.shape == (4, 4, 6) and jac[:, 0, 1].tolist() == a.tolist()


def test_alpha_is_a_float_one_per_feature_row_when_not_estimated():
    a, k = np.array([0.1, 0.2, 0.3]), np.array([0.0, 0.5, 1.0])
    (_, _, _, alpha), jac = _model().icrs_with_jacobian(np.zeros(6), a, k)
    assert alpha.dtype == np.float64 and alpha.tolist() == [1.0, 1.0, 1.0]
    assert jac.shape == (3, 4, 6) and not jac[:, 3].any()  # no alpha column, no slope
    (_, _, _, alpha), _ = _model().icrs_with_jacobian(np.zeros(6), 0.1, 0.0)
    assert alpha.dtype == np.float64 and alpha == 1.0
    (_, _, _, alpha7), jac7 = _model().icrs_with_jacobian(np.r_[np.zeros(6), 0.9], a, k)
    assert alpha7 == 0.9 and jac7[:, 3].tolist() == [[0.0] * 6 + [1.0]] * 3
