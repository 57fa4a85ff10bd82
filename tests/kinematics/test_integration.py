"""Tests of the exact constant-twist pose integration (terrain_odom.kinematics.integration).

References are hand-worked geometry (straight lines, circles), an independent
fine numerical quadrature of the kinematic ODE, high-order Taylor series of the
arc coefficients, step-by-step SE(2) composition, and central finite
differences for the Jacobian.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from terrain_odom.kinematics.integration import (
    arc_increment,
    arc_increment_jacobian,
    compose,
    integrate,
    relative_pose,
    wrap_angle,
)

TWO_PI = 2.0 * np.pi


def _assert_angles_close(a, b, atol: float) -> None:
    diff = np.asarray(wrap_angle(np.asarray(a) - np.asarray(b)))
    assert np.all(np.abs(diff) <= atol), f"max angle difference {np.abs(diff).max()}"


def _assert_poses_close(a, b, atol: float) -> None:
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape
    assert_allclose(a[..., :2], b[..., :2], rtol=0, atol=atol)
    _assert_angles_close(a[..., 2], b[..., 2], atol)


# --------------------------------------------------------------------------
# wrap_angle
# --------------------------------------------------------------------------


def test_wrap_angle_pi_boundaries() -> None:
    """Pi stays pi and -pi becomes pi."""
    out = wrap_angle([np.pi, -np.pi, 0.0, np.pi / 2, -np.pi / 2])
    assert out[0] == np.pi
    assert out[1] == np.pi
    assert out[2] == 0.0
    assert out[3] == np.pi / 2
    assert out[4] == -np.pi / 2


def test_wrap_angle_hand_worked() -> None:
    """wrap_angle reproduces hand-worked values."""
    # 3pi/2 -> -pi/2; -3pi/2 -> pi/2; 2pi -> 0; 7 -> 7 - 2pi; -7 -> 2pi - 7.
    out = wrap_angle([1.5 * np.pi, -1.5 * np.pi, TWO_PI, 7.0, -7.0])
    assert_allclose(out, [-np.pi / 2, np.pi / 2, 0.0, 7.0 - TWO_PI, TWO_PI - 7.0], atol=1e-14)


def test_wrap_angle_just_inside_minus_pi_stays() -> None:
    """The float just above -pi is left unchanged."""
    x = np.nextafter(-np.pi, 0.0)
    out = float(wrap_angle(x))
    assert -np.pi < out <= np.pi
    assert abs(out - x) < 1e-15


def test_wrap_angle_property_random() -> None:
    """Wrapped angles are in (-pi, pi] and differ by whole turns."""
    rng = np.random.default_rng(11)
    k = rng.integers(-50, 51, 2000)
    values = np.concatenate(
        [
            rng.uniform(-1e3, 1e3, 2000),
            rng.uniform(-4.0, 4.0, 2000),
            (2 * k + 1) * np.pi + rng.normal(0.0, 1e-12, 2000),  # near the cut
            k * TWO_PI,
        ]
    )
    out = wrap_angle(values)
    assert out.shape == values.shape
    assert np.all(out > -np.pi)
    assert np.all(out <= np.pi)
    turns = (values - out) / TWO_PI
    assert_allclose(turns, np.round(turns), rtol=0, atol=1e-9)
    # Values already inside (-pi, pi] come back unchanged.
    inside = (values > -np.pi) & (values <= np.pi)
    assert_allclose(out[inside], values[inside], rtol=0, atol=4.5e-16)


def test_wrap_angle_shape_preserved() -> None:
    """wrap_angle keeps the input shape."""
    assert wrap_angle(np.zeros((3, 4, 2))).shape == (3, 4, 2)
    assert np.ndim(wrap_angle(1.0)) == 0


# --------------------------------------------------------------------------
# arc_increment
# --------------------------------------------------------------------------


def test_arc_straight_line_exact() -> None:
    """Zero yaw rate gives exactly (v_x dt, v_y dt, 0)."""
    v_x = np.array([1.0, -0.3, 2.5, 0.0])
    v_y = np.array([0.0, 0.7, -0.1, 1.0])
    dt = np.array([0.1, 2.0, 0.37, 3.0])
    inc = arc_increment(v_x, v_y, 0.0, dt)
    assert_array_equal(inc, np.stack([v_x * dt, v_y * dt, np.zeros(4)], axis=-1))


@pytest.mark.parametrize("v_y", [0.0, 0.4, -1.3])
def test_arc_full_circle_returns_to_start(v_y: float) -> None:
    """A full turn returns to the start position."""
    # One full turn at any constant body velocity closes the circle.
    dt = 2.5
    inc = arc_increment(1.7, v_y, TWO_PI / dt, dt)
    assert_allclose(inc[:2], 0.0, atol=1e-14)
    assert inc[2] == pytest.approx(TWO_PI, rel=1e-15)  # not wrapped


@pytest.mark.parametrize("radius", [0.5, 2.0, 7.0])
def test_arc_quarter_circle(radius: float) -> None:
    """A quarter turn of radius R ends at (R, +-R)."""
    # Left quarter turn of radius R: start heading +x, centre at (0, R),
    # end at (R, R) heading +y. Right turn mirrors to (R, -R).
    dt = 1.3
    omega = (np.pi / 2) / dt
    inc = arc_increment(radius * omega, 0.0, omega, dt)
    assert_allclose(inc, [radius, radius, np.pi / 2], rtol=0, atol=1e-14)
    inc_r = arc_increment(radius * omega, 0.0, -omega, dt)
    assert_allclose(inc_r, [radius, -radius, -np.pi / 2], rtol=0, atol=1e-14)


def test_arc_half_circle_with_pure_lateral_speed() -> None:
    """A half turn with purely lateral speed ends 2 m behind."""
    # v_x = 0, v_y = pi (leftwards), omega = pi, dt = 1: body velocity at
    # heading theta is pi (-sin theta, cos theta); integral over [0, pi] is
    # (-2, 0) -> ends 2 m behind the start, heading pi.
    inc = arc_increment(0.0, np.pi, np.pi, 1.0)
    assert_allclose(inc, [-2.0, 0.0, np.pi], rtol=0, atol=1e-14)


def _arc_reference(v_x, v_y, phi, dt, terms: int = 30):
    """Evaluate A = sin(phi)/phi and B = (1 - cos(phi))/phi by their Taylor series."""
    a = sum((-1) ** k * phi ** (2 * k) / math.factorial(2 * k + 1) for k in range(terms))
    b = sum((-1) ** k * phi ** (2 * k + 1) / math.factorial(2 * k + 2) for k in range(terms))
    return np.stack([dt * (v_x * a - v_y * b), dt * (v_x * b + v_y * a), phi], axis=-1)


def test_arc_matches_series_reference_over_regimes() -> None:
    """arc_increment matches a 30-term Taylor-series reference."""
    phi = np.concatenate(
        [
            [0.0, 1e-12, -1e-8, 1e-5, -3e-3, 9.99e-3, 1.001e-2, -1.5e-2, 0.05],
            np.linspace(-3.0, 3.0, 61),
        ]
    )
    dt = 0.8
    v_x, v_y = 1.3, -0.7
    got = arc_increment(v_x, v_y, phi / dt, dt)
    want = _arc_reference(v_x, v_y, phi, dt)
    assert_allclose(got[:, :2], want[:, :2], rtol=0, atol=5e-14)
    assert_allclose(got[:, 2], phi, rtol=1e-15, atol=0)


def test_arc_continuous_across_series_switch() -> None:
    """Series and closed-form branches agree at the switch."""
    # _SERIES_LIMIT = 1e-2: compare the two branches at adjacent floats.
    v_x, v_y, dt = 1.3, -0.7, 1.0
    for limit in (1e-2, -1e-2):
        below = np.nextafter(limit, 0.0)
        above = np.nextafter(limit, 2 * limit)
        inc_below = arc_increment(v_x, v_y, below, dt)
        inc_above = arc_increment(v_x, v_y, above, dt)
        assert_allclose(inc_below, inc_above, rtol=0, atol=1e-12)
        jac_below = arc_increment_jacobian(v_x, v_y, below, dt)
        jac_above = arc_increment_jacobian(v_x, v_y, above, dt)
        assert_allclose(jac_below, jac_above, rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    ("v_x", "v_y", "omega", "dt"),
    [(0.8, 0.3, 1.1, 1.7), (1.5, -0.6, -2.4, 0.9), (0.2, 1.0, 0.004, 2.0)],
)
def test_arc_matches_fine_numerical_integration(v_x, v_y, omega, dt) -> None:
    """arc_increment matches a 10^5-step numerical integration."""
    # Integrate x' = v_x cos(th) - v_y sin(th), y' = v_x sin(th) + v_y cos(th),
    # th' = omega with 10^5 Euler sub-steps, each using the heading at the
    # middle of the sub-step (second order; error ~ 1e-11 here).
    n = 100_000
    h = dt / n
    th_mid = omega * h * (np.arange(n) + 0.5)
    x = h * np.sum(v_x * np.cos(th_mid) - v_y * np.sin(th_mid))
    y = h * np.sum(v_x * np.sin(th_mid) + v_y * np.cos(th_mid))
    inc = arc_increment(v_x, v_y, omega, dt)
    assert_allclose(inc, [x, y, omega * dt], rtol=0, atol=1e-9)


def test_arc_first_order_euler_converges_to_it() -> None:
    """Forward Euler converges to arc_increment at first order."""
    # Plain forward Euler (heading at the start of each sub-step) is first
    # order: its error must shrink ~10x per 10x sub-steps, towards our value.
    v_x, v_y, omega, dt = 0.8, 0.3, 1.1, 1.7
    exact = arc_increment(v_x, v_y, omega, dt)[:2]
    errors = []
    for n in (1_000, 10_000, 100_000):
        h = dt / n
        th = omega * h * np.arange(n)
        xy = h * np.array(
            [
                np.sum(v_x * np.cos(th) - v_y * np.sin(th)),
                np.sum(v_x * np.sin(th) + v_y * np.cos(th)),
            ]
        )
        errors.append(np.abs(xy - exact).max())
    assert errors[-1] < 2e-5
    assert 8 < errors[0] / errors[1] < 12
    assert 8 < errors[1] / errors[2] < 12


def test_arc_broadcasts() -> None:
    """arc_increment broadcasts its inputs; dt = 0 gives zero."""
    inc = arc_increment(np.ones((4, 1)), 0.0, np.linspace(-1, 1, 5), 0.1)
    assert inc.shape == (4, 5, 3)
    assert_array_equal(arc_increment(1.0, 2.0, 0.5, 0.0), [0.0, 0.0, 0.0])


# --------------------------------------------------------------------------
# arc_increment_jacobian
# --------------------------------------------------------------------------


def _arc_fd_jacobian(v_x, v_y, omega, dt, h):
    x0 = np.array([v_x, v_y, omega], dtype=float)
    jac = np.zeros((3, 3))
    for k in range(3):
        up, dn = x0.copy(), x0.copy()
        up[k] += h
        dn[k] -= h
        jac[:, k] = (arc_increment(*up, dt) - arc_increment(*dn, dt)) / (2 * h)
    return jac


@pytest.mark.parametrize(
    ("v_x", "v_y", "omega", "dt", "h"),
    [
        # normal regime
        (0.8, 0.3, 1.1, 1.7, 1e-6),
        (1.5, -0.6, -2.4, 0.9, 1e-6),
        (-0.4, 1.2, 3.0, 0.5, 1e-6),
        # series regime (|omega dt| < 1e-2, steps stay inside it)
        (1.2, -0.5, 2e-3, 1.5, 1e-6),
        (0.9, 0.7, -1e-5, 0.3, 1e-7),
        # omega exactly zero
        (1.1, 0.4, 0.0, 2.0, 1e-6),
        (0.0, -0.8, 0.0, 0.7, 1e-6),
    ],
)
def test_arc_jacobian_matches_central_differences(v_x, v_y, omega, dt, h) -> None:
    """arc_increment_jacobian matches central finite differences."""
    jac = arc_increment_jacobian(v_x, v_y, omega, dt)
    fd = _arc_fd_jacobian(v_x, v_y, omega, dt, h)
    assert_allclose(jac, fd, rtol=1e-6, atol=1e-8)


def test_arc_jacobian_at_zero_yaw_rate_hand_worked() -> None:
    """arc_increment_jacobian at omega = 0 matches a hand-worked matrix."""
    # omega = 0: A = 1, B = 0, A' = 0, B' = 1/2, so
    # d(dx)/domega = -v_y dt^2/2 and d(dy)/domega = v_x dt^2/2.
    v_x, v_y, dt = 1.1, 0.4, 2.0
    jac = arc_increment_jacobian(v_x, v_y, 0.0, dt)
    expected = np.array(
        [
            [dt, 0.0, -v_y * dt * dt / 2],
            [0.0, dt, v_x * dt * dt / 2],
            [0.0, 0.0, dt],
        ]
    )
    assert_allclose(jac, expected, rtol=1e-15, atol=0)


def test_arc_jacobian_vectorised() -> None:
    """Vectorised arc_increment_jacobian equals element-wise calls."""
    rng = np.random.default_rng(12)
    v_x, v_y = rng.uniform(-2, 2, (2, 6)), rng.uniform(-1, 1, (2, 6))
    omega, dt = rng.uniform(-3, 3, (2, 6)), rng.uniform(0.01, 1.0, (2, 6))
    omega[0, 0] = 0.0
    omega[0, 1] = 1e-4
    jac = arc_increment_jacobian(v_x, v_y, omega, dt)
    assert jac.shape == (2, 6, 3, 3)
    for i in range(2):
        for j in range(6):
            single = arc_increment_jacobian(v_x[i, j], v_y[i, j], omega[i, j], dt[i, j])
            assert_array_equal(jac[i, j], single)
            fd = _arc_fd_jacobian(v_x[i, j], v_y[i, j], omega[i, j], dt[i, j], 1e-7)
            assert_allclose(single, fd, rtol=1e-6, atol=1e-8)


# --------------------------------------------------------------------------
# compose / relative_pose
# --------------------------------------------------------------------------


def test_compose_hand_worked() -> None:
    """SE(2) compose reproduces a hand-worked SE(2) product."""
    # From (1, 2, pi/2) (facing world +y), 1 m forward is world +y and 0.5 m
    # left is world -x: (1 - 0.5, 2 + 1) = (0.5, 3); yaw pi/2 + pi wraps to -pi/2.
    out = compose([1.0, 2.0, np.pi / 2], [1.0, 0.5, np.pi])
    assert_allclose(out, [0.5, 3.0, -np.pi / 2], rtol=0, atol=1e-15)


def test_relative_pose_inverts_compose() -> None:
    """Function relative_pose(a, compose(a, inc)) recovers inc, yaw wrapped."""
    rng = np.random.default_rng(13)
    a = np.column_stack([rng.uniform(-5, 5, (50, 2)), rng.uniform(-np.pi, np.pi, 50)])
    inc = np.column_stack([rng.uniform(-3, 3, (50, 2)), rng.uniform(-10, 10, 50)])
    rel = relative_pose(a, compose(a, inc))
    assert_allclose(rel[:, :2], inc[:, :2], rtol=0, atol=1e-13)
    assert_allclose(rel[:, 2], wrap_angle(inc[:, 2]), rtol=0, atol=1e-13)
    assert np.all(rel[:, 2] > -np.pi) and np.all(rel[:, 2] <= np.pi)


# --------------------------------------------------------------------------
# integrate
# --------------------------------------------------------------------------


def _random_steps(rng, shape):
    v_x = rng.uniform(-1.5, 2.0, shape)
    v_y = rng.uniform(-0.5, 0.5, shape)
    omega = rng.uniform(-2.0, 2.0, shape)
    dt = rng.uniform(0.01, 0.3, shape)
    return v_x, v_y, omega, dt


def _integrate_loop(v_x, v_y, omega, dt, start):
    poses = [_wrap_pose(np.asarray(start, dtype=float))]
    for k in range(len(v_x)):
        poses.append(compose(poses[-1], arc_increment(v_x[k], v_y[k], omega[k], dt[k])))
    return np.array(poses)


def _wrap_pose(pose: np.ndarray) -> np.ndarray:
    return np.array([pose[0], pose[1], float(wrap_angle(pose[2]))])


def test_integrate_equals_step_by_step_compose() -> None:
    """The vectorised integrate equals composing arc increments one by one."""
    rng = np.random.default_rng(14)
    steps = _random_steps(rng, 40)
    start = np.array([2.0, -1.0, 2.9])
    poses = integrate(*steps, start=start)
    assert poses.shape == (41, 3)
    _assert_poses_close(poses, _integrate_loop(*steps, start), atol=1e-12)
    assert np.all(poses[:, 2] > -np.pi) and np.all(poses[:, 2] <= np.pi)


def test_integrate_constant_twist_equals_single_arc() -> None:
    """K equal steps of one twist equal a single arc of K dt."""
    # A constant twist split into K equal steps is one arc of K*dt.
    v_x, v_y, omega, dt, k = 0.9, -0.25, 0.8, 0.125, 24
    poses = integrate([v_x] * k, [v_y] * k, [omega] * k, [dt] * k)
    one = arc_increment(v_x, v_y, omega, k * dt)
    _assert_poses_close(poses[-1], one, atol=1e-12)
    # And every intermediate pose lies on the same arc.
    for i in range(k + 1):
        _assert_poses_close(poses[i], arc_increment(v_x, v_y, omega, i * dt), atol=1e-12)


def test_integrate_origin_default_and_quarter_turns() -> None:
    """Four quarter turns trace the unit circle from the origin."""
    poses = integrate([np.pi / 2] * 4, [0.0] * 4, [np.pi / 2] * 4, [1.0] * 4)
    # Unit circle centred at (0, 1): (0,0) -> (1,1) -> (0,2) -> (-1,1) -> (0,0).
    expected = np.array(
        [[0, 0, 0], [1, 1, np.pi / 2], [0, 2, np.pi], [-1, 1, -np.pi / 2], [0, 0, 0]],
        dtype=float,
    )
    _assert_poses_close(poses, expected, atol=1e-12)


def test_integrate_zero_dt_padding_leaves_pose_unchanged() -> None:
    """Steps with dt = 0 leave the pose unchanged."""
    rng = np.random.default_rng(15)
    v_x, v_y, omega, dt = _random_steps(rng, 12)
    dt[7:] = 0.0  # ragged window padded with dt = 0 (speeds are garbage there)
    start = np.array([0.3, 0.4, -2.0])
    poses = integrate(v_x, v_y, omega, dt, start=start)
    for k in range(8, 13):
        assert_array_equal(poses[k], poses[7])
    unpadded = integrate(v_x[:7], v_y[:7], omega[:7], dt[:7], start=start)
    assert_array_equal(poses[:8], unpadded)
    # Padding in the middle is a no-op too.
    dt2 = dt.copy()
    dt2[3] = 0.0
    poses2 = integrate(v_x, v_y, omega, dt2, start=start)
    assert_array_equal(poses2[4], poses2[3])


def test_integrate_vectorised_windows_equal_loop() -> None:
    """Integrating (W, K) windows equals a per-window loop."""
    rng = np.random.default_rng(16)
    w, k = 5, 15
    v_x, v_y, omega, dt = _random_steps(rng, (w, k))
    dt[1, 10:] = 0.0
    dt[3, 4:] = 0.0
    starts = np.column_stack([rng.uniform(-5, 5, (w, 2)), rng.uniform(-np.pi, np.pi, w)])
    poses = integrate(v_x, v_y, omega, dt, start=starts)
    assert poses.shape == (w, k + 1, 3)
    for i in range(w):
        single = integrate(v_x[i], v_y[i], omega[i], dt[i], start=starts[i])
        assert_allclose(poses[i], single, rtol=0, atol=1e-14)
        looped = _integrate_loop(v_x[i], v_y[i], omega[i], dt[i], starts[i])
        _assert_poses_close(poses[i], looped, atol=1e-12)


def test_integrate_shared_start_broadcasts_over_windows() -> None:
    """One start pose broadcasts over all windows."""
    rng = np.random.default_rng(17)
    steps = _random_steps(rng, (3, 6))
    start = np.array([1.0, -2.0, 0.5])
    poses = integrate(*steps, start=start)
    assert_allclose(poses[:, 0, :], np.tile(start, (3, 1)), rtol=0, atol=0)


def test_integrate_start_pose_honoured() -> None:
    """The start pose is the first pose and moves the whole trajectory."""
    rng = np.random.default_rng(18)
    steps = _random_steps(rng, 20)
    start = np.array([-3.0, 4.0, 3.0 * np.pi / 2])  # yaw outside (-pi, pi]
    poses = integrate(*steps, start=start)
    assert_allclose(poses[0, :2], start[:2], rtol=0, atol=0)
    assert poses[0, 2] == pytest.approx(-np.pi / 2, abs=1e-15)
    # Starting elsewhere is the same trajectory seen from the start frame.
    from_origin = integrate(*steps)
    _assert_poses_close(poses, compose(start, from_origin), atol=1e-12)
    _assert_poses_close(relative_pose(start, poses), from_origin, atol=1e-12)


def test_integrate_long_spin_keeps_yaw_wrapped() -> None:
    """Many turns in place keep yaw wrapped and position fixed."""
    # 10 full turns in place: yaw stays in (-pi, pi] and position at the origin.
    k = 400
    poses = integrate(np.zeros(k), np.zeros(k), np.full(k, np.pi), np.full(k, 0.05))
    assert np.all(poses[:, 2] > -np.pi) and np.all(poses[:, 2] <= np.pi)
    assert_array_equal(poses[:, :2], 0.0)
    _assert_angles_close(poses[-1, 2], 0.0, atol=1e-11)
