"""The mounting the log shows: heading offset on straight chords, apparent x_icr in turns."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

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


def test_exact_log_shows_no_offset_and_the_robots_own_x_icr(exact):
    fit = fit_mounting(exact, 0.5)
    assert fit.straight >= 20 and abs(fit.heading_offset) < math.radians(0.5)
    assert fit.x_icr == pytest.approx(TRUE[2], abs=0.05)


@pytest.mark.parametrize("antenna", [0.5, -0.3])
def test_a_lever_arm_shifts_the_apparent_x_icr_by_minus_the_antenna(exact, antenna):
    base = fit_mounting(exact, 0.5).x_icr
    fit = fit_mounting(_mounted(exact, antenna, 0.0), 0.5)
    assert fit.x_icr - base == pytest.approx(-antenna, abs=0.02)
    configured = fit_mounting(_mounted(exact, antenna, 0.0), 0.5, antenna=(antenna, 0.0))
    assert configured.x_icr == pytest.approx(base, abs=1e-6)


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
    def fit(offset, spread, n, x, x_std):
        return MountingFit(math.radians(offset), math.radians(spread), n, x, x_std, 100)

    assert mounting_findings(fit(4.0, 1.0, 100, 0.0, 0.01), 0.5) == []  # below 5 deg
    assert mounting_findings(fit(8.0, 30.0, 20, 0.0, 0.01), 0.5) == []  # not significant
    assert [c for c, _ in mounting_findings(fit(8.0, 5.0, 20, 0.0, 0.01), 0.5)] == [
        "heading_offset"
    ]
    assert mounting_findings(fit(0.0, 1.0, 100, -0.3, 0.01), 0.5) == []  # within 0.35 m
    assert mounting_findings(fit(0.0, 1.0, 100, -0.5, 0.01), 1.08) == []  # within B / 2
    assert mounting_findings(fit(0.0, 1.0, 100, -0.4, 0.2), 0.5) == []  # not significant
    ((check, message),) = mounting_findings(fit(0.0, 1.0, 100, -0.4, 0.05), 0.5)
    assert check == "lever_arm" and "0.40 m (+-0.05) behind" in message
    assert "antenna 0.40 m ahead" in message


def test_real_logs_show_small_offsets_and_x_icr(drive_dir):
    """The Warthog's ICP poses: heading within 0.6 deg of the course, |x| < 0.2 m (B = 1.08 m)."""
    measured = 0
    for path in sorted(drive_dir.glob("*.csv")):
        fit = fit_mounting(read_wheel_log(path, wheel_radius=0.30), 1.08)
        if np.isfinite(fit.heading_offset):  # too few straight stretches on some
            measured += 1
            assert abs(fit.heading_offset) < math.radians(0.6), path.name
        assert abs(fit.x_icr) < 0.2, path.name
    assert measured >= 6
