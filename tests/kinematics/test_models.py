"""Tests of the skid-steer kinematic model family (terrain_odom.kinematics.models).

Every expected value is either worked out by hand in the test, or re-derived
independently from the papers' equations written literally in their own
conventions (Baril CRV 2020 eq. 3-12, Chen J. Robotics 2023 eq. 3, Martinez
IROS 2004 eq. 7-9, 12-13), or checked with central finite differences.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from terrain_odom.kinematics.models import (
    MODELS,
    KinematicModel,
    eccentricity,
    get_model,
    icr_from_chen,
    icr_from_martinez,
    icr_to_martinez,
    steering_efficiency,
    twist_edd_asym,
    twist_edd_sym,
    twist_icr,
    twist_icr_jacobian,
    twist_idd,
    twist_linear,
    twist_roc,
)

RNG_SEED = 20240607


def _speeds(n: int = 50, seed: int = RNG_SEED) -> tuple[np.ndarray, np.ndarray]:
    """Random track speeds in [-2, 2] m/s, including straight, spin and stop."""
    rng = np.random.default_rng(seed)
    v_l = rng.uniform(-2.0, 2.0, n)
    v_r = rng.uniform(-2.0, 2.0, n)
    v_l[:4] = [1.0, 0.7, 0.0, -1.2]
    v_r[:4] = [1.0, -0.7, 0.0, 0.4]
    return v_l, v_r


def _random_icr(rng: np.random.Generator) -> tuple[float, float, float, float]:
    """Draw a valid (y_l, y_r, x_icr, alpha) with y_l > 0 > y_r and alpha != 1."""
    y_l = rng.uniform(0.1, 3.0)
    y_r = -rng.uniform(0.1, 3.0)
    x_icr = rng.uniform(-2.0, 2.0)
    alpha = rng.uniform(0.5, 1.3)
    return y_l, y_r, x_icr, alpha


# --------------------------------------------------------------------------
# Ideal differential drive
# --------------------------------------------------------------------------


def test_idd_hand_worked_values() -> None:
    """Ideal differential drive reproduces hand-worked twists."""
    # B = 0.5 m; v_l = 0.2, v_r = 0.6: v_x = 0.4, omega = 0.4 / 0.5 = 0.8.
    # v_l = 1.0, v_r = -0.5: v_x = 0.25, omega = -1.5 / 0.5 = -3.0.
    v_x, v_y, omega = twist_idd([0.2, 1.0], [0.6, -0.5], 0.5)
    assert_allclose(v_x, [0.4, 0.25], rtol=0, atol=1e-15)
    assert_array_equal(v_y, [0.0, 0.0])
    assert_allclose(omega, [0.8, -3.0], rtol=0, atol=1e-15)


def test_idd_pure_rotation() -> None:
    """Equal and opposite track speeds spin in place at omega = 2 v / B."""
    # v_l = -v_r = -v: spin in place CCW at omega = 2 v / B.
    v, b = 0.75, 1.2
    v_x, v_y, omega = twist_idd(-v, v, b)
    assert v_x == 0.0
    assert v_y == 0.0
    assert omega == pytest.approx(2.0 * v / b, rel=1e-15)
    # Reversed: clockwise.
    assert twist_idd(v, -v, b)[2] == pytest.approx(-2.0 * v / b, rel=1e-15)


def test_idd_matches_baril_eq3_matrix() -> None:
    """The ideal model equals Baril eq. 3 written as a matrix."""
    # Baril eq. 3 with r = 1 (our inputs are surface speeds).
    v_l, v_r = _speeds()
    b = 0.93
    j = np.array([[0.5, 0.5], [0.0, 0.0], [-1.0 / b, 1.0 / b]])
    expected = j @ np.vstack([v_l, v_r])
    assert_allclose(np.vstack(twist_idd(v_l, v_r, b)), expected, rtol=1e-14, atol=1e-15)


@pytest.mark.parametrize("bad_width", [0.0, -0.4, np.nan])
def test_idd_rejects_non_positive_track_width(bad_width: float) -> None:
    """A non-positive or NaN track width is rejected."""
    with pytest.raises(ValueError, match="track_width"):
        twist_idd(1.0, 2.0, bad_width)


# --------------------------------------------------------------------------
# Model family: reductions to one another
# --------------------------------------------------------------------------


def test_icr_symmetric_no_slip_equals_idd_exactly() -> None:
    """Symmetric ICRs at +-B/2 with no slip are the ideal model."""
    v_l, v_r = _speeds()
    for b in (0.5, 1.2, 0.37):
        got = twist_icr(v_l, v_r, b / 2, -b / 2, 0.0, 1.0)
        want = twist_idd(v_l, v_r, b)
        for g, w in zip(got, want, strict=True):
            assert_allclose(g, w, rtol=1e-15, atol=1e-15)
        assert_array_equal(np.abs(got[1]), 0.0)


def test_edd_sym_equals_icr_with_half_widths() -> None:
    """Symmetric extended DD is the ICR model at +-b_hat/2 with slip alpha."""
    v_l, v_r = _speeds()
    for alpha, b_hat in ((0.94, 4.46), (0.86, 3.08), (1.1, 0.6)):
        got = twist_edd_sym(v_l, v_r, alpha, b_hat)
        want = twist_icr(v_l, v_r, b_hat / 2, -b_hat / 2, 0.0, alpha)
        for g, w in zip(got, want, strict=True):
            assert_allclose(g, w, rtol=1e-14, atol=1e-15)


def test_edd_sym_matches_baril_eq8_matrix() -> None:
    """Symmetric extended DD equals Baril eq. 8 written as a matrix."""
    # J(alpha, b_hat) = alpha [[1/2, 1/2], [0, 0], [-1/b_hat, 1/b_hat]]
    v_l, v_r = _speeds()
    alpha, b_hat = 0.86, 3.08
    j = alpha * np.array([[0.5, 0.5], [0.0, 0.0], [-1.0 / b_hat, 1.0 / b_hat]])
    got = np.vstack(twist_edd_sym(v_l, v_r, alpha, b_hat))
    assert_allclose(got, j @ np.vstack([v_l, v_r]), rtol=1e-14, atol=1e-15)


def test_edd_asym_equal_slips_equals_icr_with_alpha() -> None:
    """Asymmetric extended DD with equal slips is the ICR model with alpha."""
    v_l, v_r = _speeds()
    rng = np.random.default_rng(1)
    for _ in range(5):
        y_l, y_r, x_icr, a = _random_icr(rng)
        got = twist_edd_asym(v_l, v_r, a, a, x_icr, y_l, y_r)
        want = twist_icr(v_l, v_r, y_l, y_r, x_icr, a)
        for g, w in zip(got, want, strict=True):
            assert_allclose(g, w, rtol=1e-13, atol=1e-14)


def test_edd_asym_matches_baril_eq7_matrix_literally() -> None:
    """Asymmetric extended DD equals Baril eq. 7 written literally."""
    # Baril eq. 7 (r = 1):
    #   J = 1/(y_l - y_r) [[-y_r, y_l], [x_v, -x_v], [-1, 1]] diag(alpha_l, alpha_r)
    # with Baril's warm-weather Table I values (alpha_l != alpha_r, x_v != 0).
    v_l, v_r = _speeds()
    alpha_l, alpha_r, x_v, y_l, y_r = 0.90, 0.92, -2.57, 4.66, -5.00
    j = (
        np.array([[-y_r, y_l], [x_v, -x_v], [-1.0, 1.0]])
        @ np.diag([alpha_l, alpha_r])
        / (y_l - y_r)
    )
    got = np.vstack(twist_edd_asym(v_l, v_r, alpha_l, alpha_r, x_v, y_l, y_r))
    assert_allclose(got, j @ np.vstack([v_l, v_r]), rtol=1e-13, atol=1e-14)


def test_roc_beta1_zero_equals_edd_sym_with_nominal_width() -> None:
    """ROC model with beta_1 = 0 is the symmetric extended DD with b_hat = B."""
    v_l, v_r = _speeds()
    for alpha, beta_2, b in ((0.91, 11.09, 1.2), (0.8, -0.18, 1.2), (1.0, 0.0, 0.6)):
        got = twist_roc(v_l, v_r, alpha, 0.0, beta_2, b)
        want = twist_edd_sym(v_l, v_r, alpha, b)
        for g, w in zip(got, want, strict=True):
            assert_allclose(g, w, rtol=1e-14, atol=1e-15)


def test_roc_straight_line_zero_yaw_rate_without_warnings() -> None:
    """ROC model gives zero yaw rate on a straight line, with no warning."""
    # v_l == v_r: lambda is infinite in Baril eq. 10; omega must be exactly 0,
    # including v = 0 and parameters for which y_0 would be degenerate.
    v = np.array([0.0, 1.0, -1.5, 2.0, 1e-9])
    params = [(0.91, 42.73, 11.09), (0.8, 1.36, -0.18), (1.0, -3.0, -1.0), (0.5, 1.0, 0.0)]
    with np.errstate(all="raise"):
        for alpha, b1, b2 in params:
            v_x, v_y, omega = twist_roc(v, v, alpha, b1, b2, 1.2)
            assert_array_equal(omega, 0.0)
            assert_array_equal(v_y, 0.0)
            assert_allclose(v_x, alpha * v, rtol=1e-15, atol=0)
            assert not np.any(np.isnan(v_x))


def test_roc_hand_worked_lambda_two() -> None:
    """ROC model reproduces a hand-worked turn with lambda = 2."""
    # v_l = 1, v_r = 3: lambda = |3 + 1| / |3 - 1| = 2.
    # beta_2 = sqrt(2)/2 -> 1 + beta_2 sqrt(lambda) = 2; beta_1 = 1, B = 1.2 m:
    # y_0 = 0.6 * (1 + 1/2) = 0.9 m; alpha = 0.9:
    # omega = alpha (v_r - v_l) / (2 y_0) = 0.9 * 2 / 1.8 = 1.0 rad/s,
    # v_x = alpha (v_l + v_r) / 2 = 1.8 m/s.
    alpha, b1, b2, b = 0.9, 1.0, np.sqrt(2.0) / 2.0, 1.2
    v_x, v_y, omega = twist_roc(1.0, 3.0, alpha, b1, b2, b)
    assert float(v_x) == pytest.approx(1.8, rel=1e-14)
    assert float(v_y) == 0.0
    assert float(omega) == pytest.approx(1.0, rel=1e-14)
    # Mirrored turn (lambda still 2) and driving backwards (lambda = |-4|/|-2| = 2).
    assert float(twist_roc(3.0, 1.0, alpha, b1, b2, b)[2]) == pytest.approx(-1.0, rel=1e-14)
    vx_back, _, om_back = twist_roc(-1.0, -3.0, alpha, b1, b2, b)
    assert float(vx_back) == pytest.approx(-1.8, rel=1e-14)
    assert float(om_back) == pytest.approx(-1.0, rel=1e-14)
    # Radius of curvature R = v_x / omega = lambda * y_0 (Baril eq. 10, alpha cancels).
    assert float(v_x / omega) == pytest.approx(2.0 * 0.9, rel=1e-14)


def test_roc_general_values_against_eq10_11() -> None:
    """ROC model equals Baril eq. 10-11 evaluated directly."""
    v_l, v_r = _speeds()
    turning = v_l != v_r
    v_l, v_r = v_l[turning], v_r[turning]
    alpha, b1, b2, b = 0.91, 0.7, 0.4, 1.2
    lam = np.abs((v_r + v_l) / (v_r - v_l))
    y_0 = b / 2 * (1 + b1 / (1 + b2 * np.sqrt(lam)))
    v_x, v_y, omega = twist_roc(v_l, v_r, alpha, b1, b2, b)
    assert_allclose(omega, alpha * (v_r - v_l) / (2 * y_0), rtol=1e-13)
    assert_allclose(v_x, alpha * (v_r + v_l) / 2, rtol=1e-14)


def test_roc_invalid_effective_width_gives_nan_yaw_rate() -> None:
    """ROC model yields NaN yaw rate where y_0 <= 0, as documented."""
    # beta_1 = -1, 1 + beta_2 sqrt(lambda) = 1 (spin in place, lambda = 0):
    # y_0 = B/2 * (1 - 1) = 0 -> documented NaN yaw rate, no warning.
    with np.errstate(all="raise"):
        _, _, omega = twist_roc(-1.0, 1.0, 1.0, -1.0, 5.0, 1.2)
    assert np.isnan(omega)


def test_linear_with_idd_matrix_reproduces_idd() -> None:
    """Linear model with the ideal matrix reproduces the ideal model."""
    v_l, v_r = _speeds()
    b = 0.8
    got = twist_linear(v_l, v_r, 0.5, 0.5, 0.0, 0.0, -1.0 / b, 1.0 / b)
    want = twist_idd(v_l, v_r, b)
    for g, w in zip(got, want, strict=True):
        assert_allclose(g, w, rtol=1e-14, atol=1e-15)


def test_linear_hand_worked_element_order() -> None:
    """Linear model coefficients are in row-major (g11, g12, ..., g32) order."""
    # g = [[1, 2], [3, 4], [5, 6]] applied to (v_l, v_r) = (10, 100).
    v_x, v_y, omega = twist_linear(10.0, 100.0, 1, 2, 3, 4, 5, 6)
    assert (float(v_x), float(v_y), float(omega)) == (210.0, 430.0, 650.0)


# --------------------------------------------------------------------------
# ICR geometry and the papers' conventions
# --------------------------------------------------------------------------


def test_icr_hand_worked_values() -> None:
    """ICR model reproduces a hand-worked twist."""
    # y_l = 0.5, y_r = -0.3 (d = 0.8), x_icr = 0.2, alpha = 1; v_l = 1, v_r = 2:
    # v_x = (2*0.5 - 1*(-0.3)) / 0.8 = 1.3 / 0.8 = 1.625
    # omega = (2 - 1) / 0.8 = 1.25; v_y = -1.25 * 0.2 = -0.25
    v_x, v_y, omega = twist_icr(1.0, 2.0, 0.5, -0.3, 0.2)
    assert float(v_x) == pytest.approx(1.625, rel=1e-15)
    assert float(v_y) == pytest.approx(-0.25, rel=1e-15)
    assert float(omega) == pytest.approx(1.25, rel=1e-15)


def test_icr_defining_identities_at_track_icrs() -> None:
    """Track ground-contact points at the track ICRs are at rest."""
    # Rigid-body velocity of body point (px, py): (v_x - omega py, v_y + omega px).
    # At ICR_l = (x_icr, y_l) the ground-contact point of the left track is at
    # rest: lateral  v_y + omega x_icr = 0, and longitudinally the body point
    # moves forward exactly as fast as the track surface moves backwards
    # relative to the body: v_x - omega y_l = alpha v_l. Same on the right.
    rng = np.random.default_rng(2)
    v_l, v_r = _speeds()
    for _ in range(10):
        y_l, y_r, x_icr, alpha = _random_icr(rng)
        v_x, v_y, omega = twist_icr(v_l, v_r, y_l, y_r, x_icr, alpha)
        for py, v_track in ((y_l, v_l), (y_r, v_r)):
            ground_x = (v_x - omega * py) - alpha * v_track
            ground_y = v_y + omega * x_icr
            assert_allclose(ground_x, 0.0, atol=1e-12)
            assert_allclose(ground_y, 0.0, atol=1e-12)


def test_icr_body_icr_matches_x_icr_when_turning() -> None:
    """The body ICR lies at forward coordinate x_icr."""
    # The body ICR (where the body velocity vanishes) is at
    # (-v_y/omega, v_x/omega); its x must be x_icr (Martinez eq. 3 in our axes).
    v_x, v_y, omega = twist_icr(0.4, 1.1, 0.7, -0.55, -0.33, 0.9)
    assert float(-v_y / omega) == pytest.approx(-0.33, rel=1e-14)


def test_chen_eq3_literal_matches_via_icr_from_chen() -> None:
    """Chen eq. 3 written literally matches after icr_from_chen."""
    # Chen eq. 3 in his own parameters (y_l, y_r, x_g):
    #   v_x = (v_r y_l - v_l y_r)/(y_l - y_r)
    #   v_y = -(v_l - v_r) x_g / (y_l - y_r)
    #   omega = -(v_l - v_r) / (y_l - y_r)
    v_l, v_r = _speeds()
    rng = np.random.default_rng(3)
    for _ in range(5):
        y_l, y_r, x_g = rng.uniform(0.1, 2.0), -rng.uniform(0.1, 2.0), rng.uniform(-1.0, 1.0)
        d = y_l - y_r
        chen = (
            (v_r * y_l - v_l * y_r) / d,
            -(v_l - v_r) * x_g / d,
            -(v_l - v_r) / d,
        )
        ours_params = icr_from_chen(y_l, y_r, x_g)
        assert ours_params == (y_l, y_r, -x_g)
        got = twist_icr(v_l, v_r, *ours_params)
        for g, w in zip(got, chen, strict=True):
            assert_allclose(g, w, rtol=1e-13, atol=1e-14)


def test_martinez_eq7_9_literal_matches_via_icr_from_martinez() -> None:
    """Martinez eq. 7-9 in his frame match after icr_from_martinez."""
    # Martinez frame: X to the right, Y forward, omega CCW (same sign).
    # His v_x is lateral to the right = -our v_y; his v_y is forward = our v_x.
    #   v_x^M = (V_r - V_l)/(x_r - x_l) * y_ICR                      (7)
    #   v_y^M = (V_r + V_l)/2 - (V_r - V_l)/(x_r - x_l) (x_r + x_l)/2 (8)
    #   omega = (V_r - V_l)/(x_r - x_l)                               (9)
    v_l, v_r = _speeds()
    for x_l, x_r, y_icr in ((-0.375, 0.457, 0.0492), (-0.3558, 0.4202, 0.0343), (-1.3, 0.4, -0.6)):
        w = (v_r - v_l) / (x_r - x_l)
        vx_m = w * y_icr
        vy_m = (v_r + v_l) / 2 - w * (x_r + x_l) / 2
        params = icr_from_martinez(x_l, x_r, y_icr)
        assert params == (-x_l, -x_r, y_icr)
        v_x, v_y, omega = twist_icr(v_l, v_r, *params)
        assert_allclose(v_x, vy_m, rtol=1e-13, atol=1e-14)
        assert_allclose(v_y, -vx_m, rtol=1e-13, atol=1e-14)
        assert_allclose(omega, w, rtol=1e-13, atol=1e-14)
        assert icr_to_martinez(*params) == (x_l, x_r, y_icr)


def test_martinez_track_icr_eq5_6_in_our_axes() -> None:
    """Martinez eq. 5-6 (Chen eq. 2) recover the track ICRs from the twist."""
    # Martinez eq. 5: x_ICRl = (V_l - v_y^M) / omega, with v_y^M = our v_x;
    # i.e. our y_l = -x_ICRl = (v_x - v_l)/omega (Chen eq. 2 likewise).
    y_l, y_r, x_icr = 0.41, -0.47, 0.05
    v_x, _, omega = twist_icr(0.3, 0.9, y_l, y_r, x_icr)
    assert float((v_x - 0.3) / omega) == pytest.approx(y_l, rel=1e-13)
    assert float((v_x - 0.9) / omega) == pytest.approx(y_r, rel=1e-13)


def test_steering_efficiency_and_eccentricity_martinez_table1() -> None:
    """Indices c and e match Martinez Table I means (c = 1.847, e = 0.083)."""
    # Martinez Table I mean ICRs, Auriga-alpha L = 0.42 m (Sec. IV-A);
    # the paper reports c = 1.847 and e = 0.083 (truncated to 3 decimals).
    y_l, y_r, _ = icr_from_martinez(-0.3558, 0.4202, 0.0343)
    c = float(steering_efficiency(y_l, y_r, 0.42))
    e = float(eccentricity(y_l, y_r))
    # By hand: c = (0.4202 + 0.3558)/0.42 = 0.776/0.42 = 1.847619...
    assert c == pytest.approx(0.776 / 0.42, rel=1e-12)
    assert abs(c - 1.847) < 1e-3
    # e = (0.4202 - 0.3558)/(0.4202 + 0.3558) = 0.0644/0.776 = 0.082989...
    assert e == pytest.approx(0.0644 / 0.776, rel=1e-12)
    assert abs(e - 0.083) < 1e-3


def test_steering_efficiency_and_eccentricity_martinez_dynamic_icrs() -> None:
    """Eccentricity matches Martinez's dynamic-analysis ICRs (e = 0.098)."""
    # Martinez Sec. V: x_ICRl = -0.375, x_ICRr = 0.457 m, e = 0.098 reported.
    y_l, y_r, _ = icr_from_martinez(-0.375, 0.457, 0.0492)
    e = float(eccentricity(y_l, y_r))
    assert e == pytest.approx(0.082 / 0.832, rel=1e-12)  # = 0.098557...
    assert abs(e - 0.098) < 1e-3
    # The paper prints c = 2.011 here, which is not consistent with its own
    # L = 0.42 m (0.832 / 0.42 = 1.981; 2.011 would need L = 0.4137 m), so
    # check the formula c = (x_r - x_l)/L by hand instead.
    assert float(steering_efficiency(y_l, y_r, 0.42)) == pytest.approx(0.832 / 0.42, rel=1e-12)


def test_eccentricity_sign_and_symmetry() -> None:
    """Eccentricity is zero when symmetric and positive when shifted right."""
    # Symmetric ICRs: e = 0 and ideal widths: c = 1.
    assert float(eccentricity(0.3, -0.3)) == 0.0
    assert float(steering_efficiency(0.3, -0.3, 0.6)) == pytest.approx(1.0, rel=1e-15)
    # ICRs shifted to the right (y_l + y_r < 0): positive; to the left: negative.
    assert float(eccentricity(0.2, -0.6)) == pytest.approx(0.5, rel=1e-15)
    assert float(eccentricity(0.6, -0.2)) == pytest.approx(-0.5, rel=1e-15)
    # Martinez eq. 13 literally in his frame agrees for random ICRs.
    rng = np.random.default_rng(4)
    y_l = rng.uniform(0.05, 2.0, 20)
    y_r = -rng.uniform(0.05, 2.0, 20)
    x_l, x_r = -y_l, -y_r
    assert_allclose(eccentricity(y_l, y_r), (x_r + x_l) / (x_r - x_l), rtol=1e-13, atol=1e-15)


# --------------------------------------------------------------------------
# Jacobian
# --------------------------------------------------------------------------


def _icr_fd_jacobian(v_l, v_r, params, rel_step=1e-6):
    params = np.asarray(params, dtype=float)
    jac = np.zeros(np.shape(v_l) + (3, 4))
    for k in range(4):
        h = rel_step * max(1.0, abs(params[k]))
        up, dn = params.copy(), params.copy()
        up[k] += h
        dn[k] -= h
        f_up = np.stack(twist_icr(v_l, v_r, *up), axis=-1)
        f_dn = np.stack(twist_icr(v_l, v_r, *dn), axis=-1)
        jac[..., :, k] = (f_up - f_dn) / (2 * h)
    return jac


@pytest.mark.parametrize("seed", range(6))
def test_twist_icr_jacobian_matches_central_differences(seed: int) -> None:
    """ICR Jacobian matches central finite differences."""
    rng = np.random.default_rng(100 + seed)
    params = _random_icr(rng)
    v_l, v_r = _speeds(20, seed)
    jac = twist_icr_jacobian(v_l, v_r, *params)
    assert jac.shape == (20, 3, 4)
    fd = _icr_fd_jacobian(v_l, v_r, params)
    assert_allclose(jac, fd, rtol=1e-6, atol=1e-8)


def test_twist_icr_jacobian_hand_worked() -> None:
    """ICR Jacobian reproduces a hand-worked matrix."""
    # y_l = 0.5, y_r = -0.3, x_icr = 0.2, alpha = 2; v_l = 1, v_r = 2, d = 0.8.
    # v_x = 2*(1.0 + 0.3)/0.8 = 3.25; omega = 2*1/0.8 = 2.5; v_y = -0.5
    # dv_x/dy_l = alpha y_r (v_l - v_r)/d^2 = 2*(-0.3)*(-1)/0.64 = 0.9375
    # dv_x/dy_r = alpha y_l (v_r - v_l)/d^2 = 2*0.5*1/0.64 = 1.5625
    # dv_x/dalpha = 1.3/0.8 = 1.625
    # domega/dy_l = -omega/d = -3.125; domega/dy_r = 3.125; domega/dalpha = 1.25
    # dv_y/d. = -x_icr domega/d. ; dv_y/dx_icr = -omega = -2.5
    jac = twist_icr_jacobian(1.0, 2.0, 0.5, -0.3, 0.2, 2.0)
    expected = np.array(
        [
            [0.9375, 1.5625, 0.0, 1.625],
            [0.625, -0.625, -2.5, -0.25],
            [-3.125, 3.125, 0.0, 1.25],
        ]
    )
    assert_allclose(jac, expected, rtol=1e-14, atol=1e-15)


def test_twist_icr_jacobian_broadcasts_parameter_sets() -> None:
    """ICR Jacobian over (P, 1) parameter sets equals a loop."""
    rng = np.random.default_rng(7)
    sets = np.array([_random_icr(rng) for _ in range(3)])  # (P, 4)
    v_l, v_r = _speeds(8)
    jac = twist_icr_jacobian(v_l, v_r, *(sets[:, i, None] for i in range(4)))
    assert jac.shape == (3, 8, 3, 4)
    for p in range(3):
        assert_allclose(jac[p], twist_icr_jacobian(v_l, v_r, *sets[p]), rtol=1e-15)


# --------------------------------------------------------------------------
# Singular ICR spacing
# --------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("y_l", "y_r"),
    [(0.3, 0.3), (-0.2, 0.4), (0.0, 0.0), (np.nan, -0.3), (0.3, np.nan)],
)
def test_singular_icr_raises_clear_value_error(y_l: float, y_r: float) -> None:
    """Coincident, swapped or NaN track ICRs raise a clear ValueError."""
    with np.errstate(all="raise"):
        with pytest.raises(ValueError, match="y_l > y_r"):
            twist_icr([1.0, 2.0], [0.5, 0.5], y_l, y_r, 0.1)
        with pytest.raises(ValueError, match="y_l > y_r"):
            twist_icr_jacobian([1.0, 2.0], [0.5, 0.5], y_l, y_r, 0.1)
        with pytest.raises(ValueError, match="y_l > y_r"):
            eccentricity(y_l, y_r)
        with pytest.raises(ValueError, match="y_l > y_r"):
            twist_edd_asym(1.0, 1.0, 0.9, 0.9, 0.0, y_l, y_r)


def test_singular_icr_in_one_parameter_set_of_many_raises() -> None:
    """One singular parameter set among many raises."""
    y_l = np.array([[0.4], [0.2], [0.5]])
    y_r = np.array([[-0.4], [0.2], [-0.1]])  # middle set singular
    with pytest.raises(ValueError, match="y_l > y_r"):
        twist_icr(np.ones(4), np.zeros(4), y_l, y_r, 0.0)


def test_valid_icr_never_returns_nan() -> None:
    """Valid ICR parameters always give finite twists."""
    v_l, v_r = _speeds()
    rng = np.random.default_rng(8)
    for _ in range(20):
        y_l, y_r, x_icr, alpha = _random_icr(rng)
        out = np.stack(twist_icr(v_l, v_r, y_l, y_r, x_icr, alpha))
        assert np.all(np.isfinite(out))


# --------------------------------------------------------------------------
# KinematicModel, MODELS registry, broadcasting
# --------------------------------------------------------------------------


def _random_params(model: KinematicModel, n_sets: int, rng: np.random.Generator) -> np.ndarray:
    lo = np.array([b[0] for b in model.bounds], dtype=float)
    hi = np.array([b[1] for b in model.bounds], dtype=float)
    # Stay inside the bounds but away from the far corners of the +-50 m box.
    lo, hi = np.maximum(lo, -3.0), np.minimum(hi, 3.0)
    return rng.uniform(lo, hi, size=(n_sets, len(model.bounds)))


@pytest.mark.parametrize("name", sorted(MODELS))
def test_model_twist_broadcasts_parameter_sets_like_a_loop(name: str) -> None:
    """KinematicModel.twist over (P, k) parameters equals a loop over P."""
    model = MODELS[name]
    rng = np.random.default_rng(9)
    v_l, v_r = _speeds(30)
    b = 1.2 if model.needs_track_width else None
    n_par = len(model.param_names)
    if n_par == 0:
        params = np.zeros((0,))
        out = model.twist(v_l, v_r, params, b)
        want = twist_idd(v_l, v_r, 1.2)
        for g, w in zip(out, want, strict=True):
            assert_array_equal(g, w)
        return
    params = _random_params(model, 4, rng)
    out = model.twist(v_l, v_r, params, b)
    for comp in out:
        assert comp.shape == (4, 30)
    for p in range(4):
        single = model.twist(v_l, v_r, params[p], b)
        direct = model.twist_fn(v_l, v_r, *params[p], *([b] if b is not None else []))
        for k in range(3):
            assert single[k].shape == (30,)
            assert_allclose(out[k][p], single[k], rtol=1e-15, atol=0, equal_nan=True)
            assert_allclose(single[k], direct[k], rtol=1e-15, atol=0, equal_nan=True)


def test_model_twist_icr_uses_parameter_order() -> None:
    """The icr model takes (y_l, y_r, x_icr) in that order."""
    # params = (y_l, y_r, x_icr) in that order.
    v_x, v_y, omega = get_model("icr").twist(1.0, 2.0, [0.5, -0.3, 0.2])
    assert (float(v_x), float(v_y), float(omega)) == pytest.approx((1.625, -0.25, 1.25), rel=1e-15)


def test_model_twist_roc_appends_track_width() -> None:
    """The roc model receives the nominal track width last and requires it."""
    v_x, _, omega = get_model("roc").twist(1.0, 3.0, [0.9, 1.0, np.sqrt(2) / 2], track_width=1.2)
    assert float(omega) == pytest.approx(1.0, rel=1e-14)
    assert float(v_x) == pytest.approx(1.8, rel=1e-14)
    with pytest.raises(ValueError, match="track_width"):
        get_model("roc").twist(1.0, 3.0, [0.9, 1.0, 0.5])


@pytest.mark.parametrize("name", sorted(MODELS))
def test_model_twist_wrong_parameter_count_raises(name: str) -> None:
    """A wrong parameter count raises ValueError naming the count."""
    model = MODELS[name]
    k = len(model.param_names)
    for bad in (np.zeros(k + 1), np.zeros((3, k + 2))):
        with pytest.raises(ValueError, match=f"takes {k} parameters"):
            model.twist([1.0], [1.0], bad, 1.0)
    if k > 0:
        with pytest.raises(ValueError, match=f"takes {k} parameters"):
            model.twist([1.0], [1.0], np.zeros(k - 1), 1.0)


def test_get_model_unknown_name_lists_choices() -> None:
    """An unknown model name raises, listing the choices."""
    with pytest.raises(ValueError, match="unknown kinematic model 'ackermann'") as info:
        get_model("ackermann")
    for name in MODELS:
        assert repr(name) in str(info.value)


def test_get_model_returns_registered_models() -> None:
    """get_model returns the registered model objects."""
    assert set(MODELS) == {"idd", "edd-sym", "edd-asym", "roc", "linear", "icr", "icr-slip"}
    for name, model in MODELS.items():
        assert get_model(name) is model
        assert model.name == name


@pytest.mark.parametrize("name", sorted(MODELS))
def test_model_bounds_are_well_formed(name: str) -> None:
    """Every model has one finite (lo < hi) bound per parameter."""
    model = MODELS[name]
    assert len(model.bounds) == len(model.param_names)
    for lo, hi in model.bounds:
        assert np.isfinite(lo) and np.isfinite(hi)
        assert lo < hi


def test_icr_model_bounds_keep_icrs_apart() -> None:
    """Bounds of ICR models keep y_l > 0 > y_r."""
    # Any parameter vector inside the bounds must give a non-singular model.
    for name in ("icr", "edd-asym"):
        model = MODELS[name]
        i_l, i_r = model.param_names.index("y_l"), model.param_names.index("y_r")
        assert model.bounds[i_l][0] > 0.0 > model.bounds[i_r][1]


def test_icr_slip_is_edd_asym_with_one_slip_factor() -> None:
    """icr-slip (the EKF's model) equals edd-asym with alpha_l = alpha_r."""
    rng = np.random.default_rng(3)
    v_l, v_r = rng.uniform(-2, 2, 50), rng.uniform(-2, 2, 50)
    a = MODELS["icr-slip"].twist(v_l, v_r, [0.9, -0.7, 0.2, 0.93])
    b = MODELS["edd-asym"].twist(v_l, v_r, [0.93, 0.93, 0.2, 0.9, -0.7])
    np.testing.assert_allclose(np.array(a), np.array(b), rtol=1e-12, atol=1e-15)
