"""Scores against ground truth: known answers on hand-made runs."""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.evaluation import model_twist, spatial_windows
from terrain_odom.evaluation.groundtruth import (
    feature_times,
    frame_accuracy,
    frame_truth,
    groundtruth_log,
    model_odometry_error,
    path_length,
    reconvergence,
)
from terrain_odom.kinematics import get_model
from terrain_odom.records import GroundTruth, WheelLog


def _straight_gt(n: int = 101, speed: float = 1.0, dt: float = 0.1) -> GroundTruth:
    """1 m/s along x for 10 s; grass until x = 4 m, then sand from x = 4 m."""
    t = np.arange(n) * dt
    x = speed * t
    terrain = np.where(x < 4.0 - 1e-9, "grass", "sand")
    icr = np.where((terrain == "grass")[:, None], [0.5, -0.5, 0.0], [0.8, -0.7, 0.1])
    return GroundTruth(t, np.c_[x, 0 * x, 0 * x], icr, None, terrain, "gt")


def test_path_length_of_a_square():
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]], dtype=float)
    assert path_length(square).tolist() == [0.0, 1.0, 2.0, 3.0, 4.0]


def test_frame_truth_looks_ahead_along_the_true_path():
    gt = _straight_gt()
    # at t = 3 s the robot is at x = 3: under it grass, 1.5 m ahead sand
    truth = frame_truth(gt, [3.0, 3.0, 3.0, 20.0, 9.5], [0.0, 1.5, np.nan, 0.0, 2.0])
    assert truth.tolist() == ["grass", "sand", "grass", "", ""]


def test_frame_accuracy_counts_per_true_terrain():
    truth = ["grass", "grass", "sand", "sand", "sand", ""]
    predicted = ["grass", "sand", "sand", "", "sand", "grass"]
    acc = frame_accuracy(truth, predicted).to_dict()
    assert acc["per_terrain"]["grass"] == {
        "frames": 2,
        "correct": 1,
        "accuracy": 0.5,
        "confused_with": {"sand": 1},
    }
    assert acc["per_terrain"]["sand"]["confused_with"] == {"(no label)": 1}
    assert acc["overall"] == {"frames": 5, "correct": 3, "accuracy": 0.6}


def test_feature_times_and_speedup():
    typed = feature_times(["a", "a", "b"], [1.0, 3.0, np.nan], [8.0, 8.0, 5.0])
    times = {name: t.to_dict() for name, t in typed.items()}
    assert times["a"]["roi"] == {"frames": 2, "mean_ms": 2.0, "max_ms": 3.0}
    assert times["a"]["speedup"] == 4.0
    assert times["b"]["roi"]["frames"] == 0 and times["b"]["speedup"] is None
    assert times["all"]["full_frame"]["mean_ms"] == 7.0


def _log_from(gt: GroundTruth, speed: float) -> WheelLog:
    n = len(gt)
    v = np.full(n, speed)
    pose = np.full((n, 3), np.nan)
    return WheelLog(gt.t, v, v.copy(), pose, None, np.zeros(n, dtype=int), "log")


def test_model_odometry_error_is_exact_for_a_known_scale_error():
    gt = _straight_gt()
    log = groundtruth_log(_log_from(gt, 1.0), gt)
    np.testing.assert_allclose(log.pose, gt.pose)
    edd = get_model("edd-sym")
    models = {
        "right": lambda _w: model_twist(edd, [1.0, 1.0]),
        "10 % fast": lambda _w: model_twist(edd, [1.1, 1.0]),
    }
    typed = model_odometry_error(log, gt.terrain, models, horizon=2.0)
    out = {name: m.to_dict() for name, m in typed.items()}
    assert out["right"]["mean_position_error_m"] == pytest.approx(0.0, abs=1e-9)
    # every window (>= 2 m measured) ends 10 % of its length too far
    length = spatial_windows(log, 2.0).length
    assert out["10 % fast"]["mean_position_error_m"] == pytest.approx(0.1 * length.mean(), abs=1e-9)
    assert out["10 % fast"]["translation_m_per_m"]["median"] == pytest.approx(0.1, abs=1e-9)
    assert set(out["10 % fast"]["per_terrain_mean_position_error_m"]) == {"grass", "sand"}


def test_groundtruth_must_cover_the_log():
    gt = _straight_gt()
    log = _log_from(gt, 1.0)
    longer = WheelLog(log.t + 1.0, log.v_l, log.v_r, log.pose, None, log.segment, "later log")
    with pytest.raises(ValueError, match="covers 0-10 s but the log later log spans 1-11 s"):
        groundtruth_log(longer, gt)


def test_reconvergence_counts_from_the_true_change_until_inside_the_band():
    gt = _straight_gt()  # change to sand at t = 4 s
    t = gt.t
    est = np.tile([0.5, -0.5, 0.0], (t.size, 1))
    # moves to the sand values linearly between t = 4 and 6 s, then stays
    w = np.clip((t - 4.0) / 2.0, 0.0, 1.0)[:, None]
    est = (1 - w) * est + w * np.array([0.8, -0.7, 0.1])
    (change,) = reconvergence(gt, t, est, tolerance=0.03)
    assert (change.previous, change.new, change.t) == ("grass", "sand", pytest.approx(4.0))
    assert list(change.to_dict()) == ["t", "from", "to", "settling_s", "true_icr"]
    # y_l is the slowest: within 0.03 of 0.8 once w >= 0.9, i.e. t >= 5.8 s
    assert change.settling_s == pytest.approx(1.8, abs=0.11)
    never = reconvergence(gt, t, np.tile([0.5, -0.5, 0.0], (t.size, 1)), tolerance=0.03)
    assert never[0].settling_s is None
    # the filter switching back to grass at t = 9 s (wrongly) ends the stretch: settled
    # before it, with the estimate outside the band after it
    est[t >= 9.0] = [0.5, -0.5, 0.0]
    assert reconvergence(gt, t, est, 0.03)[0].settling_s is None
    (early,) = reconvergence(gt, t, est, 0.03, resets=[(4.1, "sand"), (9.0, "grass")])
    assert early.settling_s == pytest.approx(1.8, abs=0.11)
