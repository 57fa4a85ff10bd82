"""The filters' pose measurement model: prediction, Jacobian, chords, counts."""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.config import EkfConfig
from terrain_odom.estimation.icr_ekf import IcrEkf
from terrain_odom.estimation.pose_measurement import (
    PoseUse,
    chord_turn,
    measured_rows,
    measurement,
)
from terrain_odom.kinematics import wrap_angle
from terrain_odom.kinematics.mounting import Mounting, sensor_pose

MOUNT = Mounting(0.5, -0.2, np.radians(10.0))


@pytest.mark.parametrize("rows", [[0, 1, 2], [0, 1], [2]])
@pytest.mark.parametrize("yaw", [0.3, 3.1, -1.7])
def test_jacobian_matches_finite_differences(rows, yaw):
    state = np.array([1.0, -2.0, yaw, 0.4, -0.4, 0.05, 0.9])
    h, H = measurement(state, rows, MOUNT)  # noqa: N806
    eps = 1e-6
    numeric = np.empty_like(H)
    for k in range(state.size):
        step = np.zeros(state.size)
        step[k] = eps
        up, down = (
            measurement(state + step, rows, MOUNT)[0],
            measurement(state - step, rows, MOUNT)[0],
        )
        diff = up - down
        if 2 in rows:
            diff[-1] = wrap_angle(diff[-1])
        numeric[:, k] = diff / (2 * eps)
    np.testing.assert_allclose(H, numeric, atol=1e-8)
    assert h.shape == (len(rows),)


def test_the_prediction_is_what_the_sensors_measure_at_the_filters_pose():
    state = np.array([1.0, -2.0, 3.1, 0.4, -0.4, 0.05])
    h, _ = measurement(state, [0, 1, 2], MOUNT)
    np.testing.assert_array_equal(h, sensor_pose(state[:3], MOUNT))
    np.testing.assert_array_equal(measurement(state, [2], MOUNT)[0], h[2:])


def test_a_position_needs_both_coordinates():
    assert measured_rows([1.0, 2.0, np.nan]).tolist() == [0, 1]
    assert measured_rows([1.0, np.nan, 0.1]).tolist() == [2]
    assert measured_rows([np.nan, np.nan, np.nan]).tolist() == []


def test_ekf_update_with_a_lever_arm_is_unbiased_where_the_plain_one_is_not():
    """A robot at rest at the origin facing +y; the antenna 0.5 m ahead reads (0, 0.5)."""
    mount = Mounting(0.5, 0.0, 0.0)
    for mounting, expected_y in ((mount, 0.0), (None, 0.5)):
        ekf = IcrEkf(EkfConfig(), pose=[0.0, 0.0, np.pi / 2], mounting=mounting)
        for _ in range(50):
            ekf.update([0.0, 0.5, np.pi / 2])
        assert ekf.pose[1] == pytest.approx(expected_y, abs=1e-3)


def test_ekf_heading_offset_is_subtracted():
    ekf = IcrEkf(EkfConfig(), mounting=Mounting(0.0, 0.0, 0.2))
    for _ in range(50):
        ekf.update([np.nan, np.nan, 0.5])
    assert ekf.pose[2] == pytest.approx(0.3, abs=1e-3)


def test_pose_use_counts_each_component_and_an_incomplete_position():
    use = PoseUse()
    for z in ([1.0, 2.0, 0.1], [1.0, np.nan, 0.1], [np.nan, np.nan, 0.2]):
        z = np.array(z)
        use.measured(measured_rows(z), z)
    assert (use.position, use.heading) == (1, 3)
    assert use.dropped == {"position: x without y (or y without x)": 1}
    use.used("heading")
    assert use.summary().startswith("position 0 of 1 used, heading 1 of 3 (dropped: 1 position")


def test_chord_turn_jacobian_matches_finite_differences():
    """Two pose changes linear in 3 parameters; the antenna off the reference point."""
    rng = np.random.default_rng(1)
    a1, a2 = rng.normal(size=(3, 3)), rng.normal(size=(3, 3))
    base1, base2 = np.array([1.0, 0.3, 0.4]), np.array([0.8, -0.2, -0.3])
    arm = np.array([0.5, -0.2])

    def h(p):
        return chord_turn(base1 + a1 @ p, a1, base2 + a2 @ p, a2, arm)

    p0 = np.array([0.05, -0.02, 0.03])
    value, jac = h(p0)
    numeric = np.column_stack([(h(p0 + e)[0] - h(p0 - e)[0]) / 2e-6 for e in np.eye(3) * 1e-6])
    np.testing.assert_allclose(jac, numeric, atol=1e-7)
    assert value.shape == (2,)


def test_chord_turn_of_an_antenna_ahead_on_a_circle():
    """On a circle the antenna ahead drives a circle too: its chords turn as the robot does."""
    angle, radius = 0.4, 2.0
    change = [radius * np.sin(angle), radius * (1 - np.cos(angle)), angle]
    arm = [0.5, 0.0]
    h, _ = chord_turn(change, np.zeros((3, 1)), change, np.zeros((3, 1)), arm)
    antenna_radius = np.hypot(radius, 0.5)
    assert h[0] == pytest.approx(2 * antenna_radius * np.sin(angle / 2))
    assert h[1] == pytest.approx(angle)
