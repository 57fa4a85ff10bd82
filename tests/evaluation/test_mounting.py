"""The mounting the log shows: heading offset on straight chords, the lever arm in turns."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from terrain_odom.evaluation.calibration import LeverArm
from terrain_odom.evaluation.mounting import MountingFit, fit_mounting, mounting_findings
from terrain_odom.io import read_wheel_log
from terrain_odom.kinematics import wrap_angle
from terrain_odom.records import WheelLog
from terrain_odom.sim.model_log import constant_model_log

TRUE = (0.42, -0.40, 0.2)  # y_l, y_r, x_icr of an icr-model robot, m


@pytest.fixture(scope="module")
def exact() -> WheelLog:
    """Four minutes of an icr-model robot, poses at 10 Hz without noise."""
    return constant_model_log("icr", TRUE, seconds=240.0, seed=2, track_width=0.5, noise=(0, 0, 0))


def _mounted(log: WheelLog, antenna: float, offset: float) -> WheelLog:
    """Return the run as a GPS ``antenna`` m ahead and a heading ``offset`` rad off read it."""
    pose = log.pose.copy()
    pose[:, 0] += antenna * np.cos(log.pose[:, 2])
    pose[:, 1] += antenna * np.sin(log.pose[:, 2])
    pose[:, 2] = wrap_angle(log.pose[:, 2] + offset)
    return dataclasses.replace(log, pose=pose)


def test_exact_log_shows_no_offset_and_the_robots_own_icr_point(exact):
    """The lever arm is the antenna (here 0) minus ``(x_icr, (y_l + y_r) / 2)``."""
    fit = fit_mounting(exact, 0.5)
    assert fit.straight >= 20 and abs(fit.heading_offset) < math.radians(0.5)
    assert fit.lever.x == pytest.approx(-TRUE[2], abs=0.02)
    assert fit.lever.y == pytest.approx(-0.5 * (TRUE[0] + TRUE[1]), abs=0.02)


@pytest.mark.parametrize(("antenna", "reported"), [(0.5, False), (-0.3, True)])
def test_a_lever_arm_moves_the_fit_by_the_antenna_and_configured_it_is_not_reported(
    exact, antenna, reported
):
    """0.5 m ahead of x_icr 0.2: 0.3 m, within 0.35 m; 0.3 m behind: 0.5 m, reported."""
    base = fit_mounting(exact, 0.5).lever.x
    fit = fit_mounting(_mounted(exact, antenna, 0.0), 0.5)
    assert fit.lever.x - base == pytest.approx(antenna, abs=0.02)
    assert [c for c, _ in mounting_findings(fit, 0.5)] == ["lever_arm"] * reported
    configured = fit_mounting(_mounted(exact, antenna, 0.0), 0.5, antenna=(antenna, 0.0))
    assert configured.lever == fit.lever and configured.antenna == (antenna, 0.0)
    assert mounting_findings(configured, 0.5) == []


@pytest.mark.parametrize("degrees", [10.0, -4.0])
def test_heading_offset_is_the_median_of_heading_minus_course(exact, degrees):
    offset = math.radians(degrees)
    fit = fit_mounting(_mounted(exact, 0.0, offset), 0.5)
    assert fit.heading_offset == pytest.approx(offset, abs=math.radians(0.5))
    corrected = fit_mounting(_mounted(exact, 0.0, offset), 0.5, offset=offset)
    assert abs(corrected.heading_offset) < math.radians(0.5)


def test_reversing_gives_the_same_offset(exact):
    """Driving backwards, the course is the heading plus pi."""
    backwards = dataclasses.replace(exact, v_l=-exact.v_r, v_r=-exact.v_l)
    pose = backwards.pose.copy()  # the same path, the robot turned round and reversing
    pose[:, 2] = wrap_angle(pose[:, 2] + np.pi + math.radians(5.0))
    fit = fit_mounting(dataclasses.replace(backwards, pose=pose), 0.5)
    assert fit.heading_offset == pytest.approx(math.radians(5.0), abs=math.radians(0.5))


def test_findings_need_size_and_significance():
    def fit(offset, spread, n, x, x_std, antenna=0.0):
        lever = LeverArm(x, 0.0, x_std, x_std, 0.5)
        return MountingFit(math.radians(offset), math.radians(spread), n, lever, (antenna, 0.0), 1)

    assert mounting_findings(fit(4.0, 1.0, 100, 0.0, 0.01), 0.5) == []  # below 5 deg
    assert mounting_findings(fit(8.0, 30.0, 20, 0.0, 0.01), 0.5) == []  # not significant
    assert [c for c, _ in mounting_findings(fit(8.0, 5.0, 20, 0.0, 0.01), 0.5)] == [
        "heading_offset"
    ]
    assert mounting_findings(fit(0.0, 1.0, 100, -0.3, 0.01), 0.5) == []  # within 0.35 m
    assert mounting_findings(fit(0.0, 1.0, 100, -0.5, 0.01), 1.08) == []  # within B / 2
    assert mounting_findings(fit(0.0, 1.0, 100, -0.4, 0.2), 0.5) == []  # not significant
    assert mounting_findings(fit(0.0, 1.0, 100, -1.2, 0.05, -1.0), 0.5) == []  # configured
    ((check, message),) = mounting_findings(fit(0.0, 1.0, 100, -0.4, 0.05), 0.5)
    assert check == "lever_arm" and "x = -0.40 m (+-0.05)" in message
    assert "set it to -0.40, or to auto" in message
    # a configured antenna far off a lever arm the log cannot tell from 0: measure it
    ((check, message),) = mounting_findings(fit(0.0, 1.0, 100, -0.4, 0.2, 5.0), 0.5)
    assert check == "lever_arm" and "-5.40 m from pose_sensor.antenna_x +5.00" in message
    assert "measure the antenna (the log cannot tell it from 0), or set 0" in message


def test_real_logs_show_small_offsets_and_x_icr(drive_dir):
    """The Warthog's ICP poses: heading within 0.6 deg of the course, lever arm < 0.3 m, no finding."""
    measured = levers = 0
    for path in sorted(drive_dir.glob("*.csv")):
        fit = fit_mounting(read_wheel_log(path, wheel_radius=0.30), 1.08)
        if np.isfinite(fit.heading_offset):  # too few straight stretches on some
            measured += 1
            assert abs(fit.heading_offset) < math.radians(0.6), path.name
        if np.isfinite(fit.lever.x):  # too few 10-s windows of positions on the windows_ logs
            levers += 1
            assert abs(fit.lever.x) < 0.3 and abs(fit.lever.y) < 0.3, path.name
        assert mounting_findings(fit, 1.08) == [], path.name
    assert measured >= 6 and levers >= 6
