"""The real ROS 1 bag ``../shared/data/bags/jackal_odom_imu.bag``: import, run, evaluate.

A Jackal's diff-drive controller odometry (50 Hz) and an IMU (50 Hz), 61 s;
no external pose reference (see its README and docs/bags.md).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from terrain_odom.app.bag_import import import_bag
from terrain_odom.io.bag.options import ImportOptions
from terrain_odom.io.bag.reader import summarize_bag
from terrain_odom.io.wheel_log import read_wheel_log, write_wheel_log

ODOM, IMU = "/jackal_velocity_controller/odom", "/imu/data"
TRACK = 0.563  # jackal_control: URDF wheel separation 0.37559 m x wheel_separation_multiplier 1.5


def test_inspect_real_bag(jackal_bag: Path) -> None:
    summary = summarize_bag(jackal_bag, progress=False)
    topics = {t.topic: (t.count, round(t.rate or 0, 1), t.roles) for t in summary.topics}
    assert topics == {IMU: (3061, 50.0, ("heading",)), ODOM: (3060, 50.0, ("wheels", "pose"))}


def test_import_real_bag_odometry_twist_and_imu_heading(jackal_bag: Path, tmp_path: Path) -> None:
    opts = ImportOptions(ODOM, heading_topic=IMU, track_width=TRACK)
    result = import_bag(jackal_bag, tmp_path, opts, progress=False)
    log = read_wheel_log(result.log_csv)
    assert (result.rows, result.heading_rows, result.segments) == (6119, 3059, 1)
    assert result.skipped == {"merge": {"heading outside the wheel samples": 2}}
    # the first odometry message by hand (read above with rosbags): v = 0.0037184, w = 0.0063572
    v, w = 0.003718422999909875, 0.00635724555666083
    np.testing.assert_allclose(
        [log.v_l[0], log.v_r[0]], [v - w * TRACK / 2, v + w * TRACK / 2], atol=1e-9
    )
    # header stamps: the first odometry message is stamped 47.584 s (receive 47.585 s)
    assert json.loads(result.import_json.read_text())["time_origin_ns"] == 47 * 10**9
    assert log.t[0] == pytest.approx(0.584)
    # the skid: the IMU turns 4.77 rad over the bag, the controller's twist (ideal
    # differential drive on the wheel speeds) 35.7 rad, 7.5 times as much (docs/bags.md)
    yaw = np.unwrap(log.pose[log.has_yaw, 2])
    wheel_turn = np.sum(np.diff(log.t) * (log.v_r - log.v_l)[:-1] / TRACK)
    assert (yaw[-1] - yaw[0], wheel_turn) == pytest.approx((4.773, 35.67), abs=0.01)


def test_slip_ekf_follows_the_imu_heading_of_the_real_bag(jackal_bag: Path, tmp_path: Path) -> None:
    from terrain_odom.cli.main import main

    opts = ImportOptions(ODOM, heading_topic=IMU, track_width=TRACK)
    result = import_bag(jackal_bag, tmp_path / "imp", opts, progress=False)
    log = read_wheel_log(result.log_csv)
    first = log.t < 15.0  # the first 15 s keep the test short
    short = log.take(first)
    write_wheel_log(tmp_path / "log15.csv", short)
    argv = [
        "run",
        "--wheels",
        str(tmp_path / "log15.csv"),
        "--config",
        str(result.config_yaml),
        "--out",
        str(tmp_path / "run"),
        "--estimator",
        "slip-ekf",
    ]
    assert main(argv) == 0
    report = json.loads((tmp_path / "run" / "report.json").read_text())
    headings = int(np.count_nonzero(short.has_yaw))
    assert report["counts"]["updates"] == headings - 1  # every heading but the first (its anchor)


def test_run_and_evaluate_on_the_imported_real_bag(jackal_bag: Path, tmp_path: Path) -> None:
    from terrain_odom.cli.main import main

    opts = ImportOptions(ODOM, pose_topic=ODOM, track_width=TRACK)
    result = import_bag(jackal_bag, tmp_path / "imp", opts, progress=False)
    out = tmp_path / "eval"
    argv = [
        "evaluate",
        "--wheels",
        str(result.log_csv),
        "--config",
        str(result.config_yaml),
        "--out",
        str(out),
    ]
    assert main(argv) == 0
    idd = json.loads((out / "evaluation.json").read_text())["models"]["idd (B=0.563 m)"]
    # the ideal differential drive on the imported track speeds re-integrates the controller's
    # own pose: a check of the import (not of the robot), within 1 % of the distance
    assert idd["translation_m_per_m"]["median"] < 0.01
