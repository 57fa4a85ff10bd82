"""Tests of the 2-s prediction metric, on simulated logs (slip EKF vs ICR EKF vs idd)."""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.config import Config, EkfConfig, IcrState, RobotConfig, SlipEkfConfig
from terrain_odom.estimation.odometry import run_icr_ekf, run_slip_ekf
from terrain_odom.evaluation import (
    icr_twist_from_rows,
    model_twist,
    prediction_errors,
    prediction_windows,
    slip_twist_from_rows,
)
from terrain_odom.kinematics import get_model
from terrain_odom.kinematics.slip import SlipModel
from terrain_odom.records import WheelLog
from terrain_odom.sim.slip_scenario import TRACK_WIDTH, feature_slip_scenario


def _line_log(n: int = 9) -> WheelLog:
    t = np.arange(n) * 0.5
    pose = np.c_[t, np.zeros(n), np.zeros(n)]
    return WheelLog(t, np.ones(n), np.ones(n), pose, None, np.zeros(n, dtype=int))


def test_windows_end_near_the_horizon_and_stay_in_their_segment():
    log = _line_log()
    w = prediction_windows(log, 2.0)
    assert w.start.tolist() == [0, 1, 2, 3, 4] and w.end.tolist() == [4, 5, 6, 7, 8]
    seg = WheelLog(log.t, log.v_l, log.v_r, log.pose, None, np.array([0] * 5 + [1] * 4))
    assert prediction_windows(seg, 2.0).start.tolist() == [0]
    assert len(prediction_windows(log, 1.2, tolerance=0.1)) == 0  # no pose near t + 1.2 s


def test_exact_model_has_zero_error_and_wrong_width_does_not():
    log = _line_log()
    w = prediction_windows(log)
    exact = prediction_errors(log, w, model_twist(get_model("idd"), [], 1.0))
    assert exact.position == pytest.approx(0.0, abs=1e-12) and exact.count == 5
    fast = prediction_errors(log, w, model_twist(get_model("edd-sym"), [1.1, 1.0]))
    assert fast.position == pytest.approx(0.2)  # 10 % of 2 m
    none = prediction_errors(
        log, prediction_windows(log, 9.0), model_twist(get_model("idd"), [], 1.0)
    )
    assert none.count == 0 and np.isnan(none.position)


def test_slip_ekf_beats_the_icr_ekf_at_1_hz_pose_and_10_hz_wheels():
    """Sec. 4.2: same data for both filters; the slip EKF's 2-s predictions are better."""
    scenario = feature_slip_scenario([1.0, 0.5, 1.2, 0.3, 0.4, 0.2], duration=120.0, seed=3)
    log = scenario.log
    cfg = Config(
        robot=RobotConfig(track_width=TRACK_WIDTH),
        slip_ekf=SlipEkfConfig(estimate_alpha=False),
        ekf=EkfConfig(estimate_alpha=False, initial=IcrState(y_l=1.23, y_r=-1.23)),
    )
    w = prediction_windows(log)
    slip = run_slip_ekf(log, cfg)
    model = SlipModel.from_config(cfg.slip_ekf, TRACK_WIDTH)
    e_slip = prediction_errors(log, w, slip_twist_from_rows(w, slip.states[:, 6:], model))
    icr = run_icr_ekf(log, cfg)
    cols = dict(zip(icr.names, icr.states.T, strict=True))
    e_icr = prediction_errors(
        log, w, icr_twist_from_rows(w, cols["y_l"], cols["y_r"], cols["x_icr"])
    )
    e_idd = prediction_errors(log, w, model_twist(get_model("idd"), [], TRACK_WIDTH))
    assert e_slip.position < 0.7 * e_icr.position < e_idd.position
    assert e_slip.heading < 0.5 * e_icr.heading < e_idd.heading
