"""Scores against ground truth at their boundaries: exact times, several changes, hand answers.

Written for the survivors of a mutation run (docs/testing.md): each test
states a property with a known answer on a hand-made run whose times and
positions are exact in binary (steps of 0.5).
"""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.errors import EstimationError
from terrain_odom.evaluation import model_twist, spatial_windows
from terrain_odom.evaluation.groundtruth import (
    frame_accuracy,
    frame_truth,
    groundtruth_log,
    model_odometry_error,
    reconvergence,
)
from terrain_odom.kinematics import get_model
from terrain_odom.records import GroundTruth, WheelLog

ICR = {
    "A": [0.5, -0.5, 0.0],
    "B": [0.8, -0.7, 0.1],
    "C": [0.6, -0.6, 0.2],
    "D": [0.9, -0.9, 0.3],
    "grass": [0.5, -0.5, 0.0],
    "sand": [0.8, -0.7, 0.1],
}


def _gt(terrain_at, seconds: float = 20.0, dt: float = 0.5) -> GroundTruth:
    """Drive 1 m/s along x (``x = t``, y and yaw 0); the terrain of each row from its time."""
    t = np.arange(0.0, seconds, dt)
    terrain = np.array([terrain_at(v) for v in t])
    icr = np.array([ICR[k] for k in terrain])
    return GroundTruth(t, np.c_[t, 0 * t, 0 * t], icr, None, terrain, "gt")


def _four(t: float) -> str:
    """Return A until 5 s, B until 10 s, C until 15 s, then D: three changes."""
    return "ABCD"[min(int(t // 5.0), 3)]


def _lagged(gt: GroundTruth, rows: int) -> np.ndarray:
    """Return an estimate that takes each terrain's true ICRs ``rows`` rows after the change."""
    return np.r_[np.tile(gt.icr[0], (rows, 1)), gt.icr[:-rows]]


def test_every_change_settles_within_its_own_stretch():
    gt = _gt(_four)
    est = _lagged(gt, 1)  # outside the band only on the change's own row
    out = reconvergence(gt, gt.t, est, tolerance=0.01)
    assert [(c.t, c.previous, c.new) for c in out] == [
        (5.0, "A", "B"),
        (10.0, "B", "C"),
        (15.0, "C", "D"),
    ]
    # the row at the change is outside the band: one row (0.5 s) to settle
    assert [c.settling_s for c in out] == [0.5, 0.5, 0.5]
    assert out[0].true_icr == {"y_l": 0.8, "y_r": -0.7, "x_icr": 0.1}
    assert out[2].to_dict()["true_icr"] == {"y_l": 0.9, "y_r": -0.9, "x_icr": 0.3}


def test_given_changes_replace_the_ground_truths_own():
    gt = _gt(_four)
    est = _lagged(gt, 1)
    out = reconvergence(gt, gt.t, est, 0.01, changes=[(5.0, "A", "B"), (10.0, "B", "C")])
    # the last given change's stretch runs to the end, through D: never settles to C
    assert [(c.t, c.settling_s) for c in out] == [(5.0, 0.5), (10.0, None)]


def test_a_change_without_estimates_after_it_never_settles():
    gt = _gt(_four)
    early = gt.t < 5.0  # the estimates stop before the first change
    out = reconvergence(gt, gt.t[early], _lagged(gt, 1)[early], 0.01)
    assert [c.settling_s for c in out] == [None, None, None]


def test_a_reset_at_the_changes_own_time_does_not_end_its_stretch():
    gt = _gt(_four)
    est = _lagged(gt, 1)
    # a switch to another terrain at the very time of the change does not come after it
    (first, *_) = reconvergence(gt, gt.t, est, 0.01, resets=[(5.0, "A")])
    assert first.settling_s == 0.5
    # one after it does: the stretch ends before the estimate reaches the band
    (first, *_) = reconvergence(gt, gt.t, est, 0.01, resets=[(5.5, "A")])
    assert first.settling_s is None


def test_frame_truth_at_an_exact_path_length_and_at_both_ends_of_the_truth():
    gt = _gt(lambda t: "grass" if t < 2.0 else "sand", seconds=5.5)  # rows 0 .. 5 s
    # at t = 1 s the robot is at x = 1; ground 0.5 m ahead is the row at x = 1.5 exactly (grass)
    truth = frame_truth(gt, [1.0, 1.0, 0.0, 5.0, 5.0 + 1e-6], [0.5, 0.5 + 1e-6, 0.0, 0.0, 0.0])
    assert truth.tolist() == ["grass", "sand", "grass", "sand", ""]


def test_groundtruth_log_takes_each_pose_column_from_its_own():
    t = np.arange(0.0, 4.5, 0.5)
    pose = np.c_[t, 2.0 * t, np.full(t.size, 0.1)]
    gt = GroundTruth(t, pose, np.tile(ICR["A"], (t.size, 1)), None, np.full(t.size, "A"), "gt")
    mid = t[:-1] + 0.25
    log = WheelLog(mid, np.ones(mid.size), np.ones(mid.size), np.zeros((mid.size, 3)), None,
                   np.zeros(mid.size, int))  # fmt: skip
    np.testing.assert_allclose(groundtruth_log(log, gt).pose, np.c_[mid, 2.0 * mid, 0.1 + 0 * mid])


def test_frame_accuracy_counts_the_right_frames_of_each_terrain():
    acc = frame_accuracy(["sand"] * 3 + ["grass"], ["sand", "", "sand", "sand"])
    assert (acc.per_terrain["sand"].frames, acc.per_terrain["sand"].correct) == (3, 2)
    assert (acc.per_terrain["grass"].frames, acc.per_terrain["grass"].correct) == (1, 0)


def _log_of(gt: GroundTruth) -> WheelLog:
    n = len(gt)
    pose = np.full((n, 3), np.nan)
    return groundtruth_log(WheelLog(gt.t, np.ones(n), np.ones(n), pose, None, np.zeros(n, int)), gt)


def test_model_odometry_error_per_terrain_heading_and_the_windows_it_was_made_for():
    gt = _gt(lambda t: "grass" if t < 4.0 else "sand", seconds=10.5)
    log = _log_of(gt)
    edd = get_model("edd-sym")

    def fast_on_sand(w):  # 10 % too far in the windows starting on sand, exact on grass
        return model_twist(edd, np.where((gt.terrain[w.start] == "sand")[:, None], [1.1, 1.0],
                                         [1.0, 1.0]))  # fmt: skip

    def turning(_w):  # straight at the right speed, with a yaw rate of 0.1 rad/s
        return lambda v_l, v_r, _i: (0.5 * (v_l + v_r), 0.0 * v_l, 0.1 + 0.0 * v_l)

    out = model_odometry_error(log, gt.terrain, {"sand": fast_on_sand, "turn": turning}, 1.0)
    windows = spatial_windows(log, 1.0)
    on_sand = gt.terrain[windows.start] == "sand"
    assert out["sand"].windows == len(windows) == 19  # a window from every row 0 .. 9 s
    per = out["sand"].per_terrain_mean_position_error_m
    assert per["grass"] == pytest.approx(0.0, abs=1e-12)
    assert per["sand"] == pytest.approx(0.1 * windows.length[on_sand].mean(), abs=1e-12)
    # 1 m at 1 m/s: 1 s of 0.1 rad/s in every window
    assert out["turn"].mean_heading_error_deg == pytest.approx(np.degrees(0.1), abs=1e-9)
    d = out["turn"].to_dict()
    assert d["mean_heading_error_deg"] == out["turn"].mean_heading_error_deg
    assert d["windows"] == 19


def test_model_odometry_error_with_one_window_or_none():
    log = _log_of(_gt(lambda t: "A", seconds=10.5))  # 10 m in all
    exact = {"idd": lambda _w: model_twist(get_model("idd"), [], 1.0)}
    assert model_odometry_error(log, log.t.astype(str), exact, 10.0)["idd"].windows == 1
    with pytest.raises(EstimationError, match="no 10.5 m window .* travels less than 10.5 m"):
        model_odometry_error(log, log.t.astype(str), exact, 10.5)
