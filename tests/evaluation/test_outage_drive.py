"""Outage and position windows on the real Warthog grass log degraded to a GPS and an IMU.

``terrain_odom.sim.degrade`` turns the log's ICP poses into 2.5-Hz fixes of
an antenna 1 m behind (0.8 m noise) and 50-Hz headings 2.7 rad off with a
slow 15-deg disturbance; the clean log is the truth. Scored from the true
heading, a constant ICR model (fitted offline on asphalt, config/warthog.yaml)
and the ideal differential drive must come out as on the clean log.
"""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.evaluation import (
    model_twist,
    outage_table,
    sparse_window_errors,
    spatial_windows,
    summarize,
    window_errors,
)
from terrain_odom.io import read_wheel_log
from terrain_odom.kinematics import get_model, twist_icr
from terrain_odom.sim.degrade import Degradation, degrade_log

GRASS = "warthog_wheels_grass_2024_7_29_14h4s53.csv"
ICR = (1.006, -0.884, 0.095, 0.935)  # config/warthog.yaml's initial ICRs
B = 1.08


@pytest.fixture(scope="module")
def clean(drive_dir):
    return read_wheel_log(drive_dir / GRASS, wheel_radius=0.3)


def _models(log):
    return {
        "icr": twist_icr(log.v_l, log.v_r, *ICR),
        "idd": get_model("idd").twist(log.v_l, log.v_r, [], B),
    }


def _medians(table):
    return {d: {k: e.position_stats.median for k, e in m.items()} for d, m in table.items()}


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_outages_of_the_degraded_log_tell_what_the_clean_log_tells(clean, seed):
    truth = _medians(outage_table(clean, (30.0, 60.0), lambda r: clean.pose[r, 2], _models(clean)))
    out = degrade_log(clean, Degradation(latency=0.0, gps_walk=0.0, seed=seed))
    log, rows = out.log, np.flatnonzero(clean.has_pose)

    def true_yaw(r):
        return np.interp(log.t[r], clean.t[rows], np.unwrap(clean.pose[rows, 2]))

    table = outage_table(log, (30.0, 60.0), true_yaw, _models(log), antenna=(-1.0, 0.0))
    assert {d: len(m["icr"].windows) for d, m in table.items()} == {30.0: 9, 60.0: 6}
    got = _medians(table)
    for d in (30.0, 60.0):
        assert got[d]["icr"] < 0.5 * got[d]["idd"]  # the Warthog skids: B = 1.08 m is far off
        # 0.8-m GPS noise on both ends, windows starting up to 0.4 s apart, medians of 6-9
        assert got[d]["icr"] == pytest.approx(truth[d]["icr"], abs=2.0)
        assert got[d]["idd"] == pytest.approx(truth[d]["idd"], abs=2.0)
    assert truth[30.0]["icr"] < 0.8 and truth[60.0]["idd"] > 15.0  # the clean figures


def test_position_windows_of_the_degraded_log(clean):
    out = degrade_log(clean, Degradation(latency=0.0, gps_walk=0.0, heading_wander=0.0, seed=0))
    w = spatial_windows(out.log, 2.0, anchor="position")
    assert 250 < len(w) < 300
    icr = model_twist(get_model("icr-slip"), list(ICR))
    idd = model_twist(get_model("idd"), [], B)
    errors = {
        name: summarize(sparse_window_errors(out.log, w, tw, antenna=(-1.0, 0.0)))
        for name, tw in (("icr", icr), ("idd", idd))
    }
    clean_w = spatial_windows(clean, 2.0)
    clean_idd = summarize(window_errors(clean, clean_w, idd)).rotation.median
    # the heading change (deg/m) from the IMU, offset 2.7 rad and all, as from ICP
    assert errors["idd"].rotation.median == pytest.approx(clean_idd, rel=0.25)
    assert errors["icr"].rotation.median < 0.25 * errors["idd"].rotation.median
    assert errors["icr"].rotation.count == len(w)
