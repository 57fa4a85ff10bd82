"""``run`` on GPS logs as a new user tries them: fixes alone, and a mounted GPS and IMU."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from terrain_odom.cli.main import main
from terrain_odom.config import load_config
from terrain_odom.io.wheel_log import write_wheel_log
from terrain_odom.records import WheelLog
from terrain_odom.sim import TERRAIN_TABLE
from terrain_odom.sim.model_log import constant_model_log


@pytest.fixture(scope="module")
def logs(tmp_path_factory, recording):
    """Two minutes on grass: GPS 0.5 m ahead (0.3 m, 2.5 Hz), IMU 10 deg off; and fixes alone."""
    sim = recording(
        120.0,
        seed=2,
        scenario="mixed",
        terrain="grass",
        pose_rate=2.5,
        sigma_xy=0.3,
        antenna=(0.5, 0.0),
        heading_offset=math.radians(10.0),
    ).sim
    folder = tmp_path_factory.mktemp("gps")
    segment = np.zeros(sim.motion.t.size, dtype=int)
    log = WheelLog(sim.motion.t, sim.v_l, sim.v_r, sim.measured_pose, None, segment, "<sim>")
    fixes = sim.measured_pose.copy()
    fixes[:, 2] = np.nan
    write_wheel_log(folder / "mounted.csv", log)
    write_wheel_log(folder / "fixes.csv", dataclasses.replace(log, pose=fixes))
    (folder / "gps.yaml").write_text("ekf: {sigma_r: {x: 0.3, y: 0.3}}\n")  # the GPS's noise
    (folder / "mounted.yaml").write_text(
        "ekf: {sigma_r: {x: 0.3, y: 0.3, yaw: 0.01}}\n"
        "pose_sensor: {antenna_x: 0.5, heading_offset: auto}\n"
    )
    return folder


def test_fixes_alone_update_with_counts_on_the_console_and_in_the_report(logs, tmp_path, capsys):
    out = tmp_path / "out"
    args = ["run", "--wheels", str(logs / "fixes.csv"), "--out", str(out)]
    assert main([*args, "--config", str(logs / "gps.yaml")]) == 0
    lines = capsys.readouterr().out.splitlines()
    (pose,) = [line for line in lines if line.startswith("pose:")]
    assert pose == "pose:       position 300 of 300 used, heading 0 of 0"
    report = json.loads((out / "report.json").read_text())
    use = report["counts"]["pose_components"]
    assert use["position"] == report["counts"]["pose_measurements"] == use["used_position"] == 300
    # the fixes before the heading from the course (3 m of travel) hold the position
    assert 2 < use["used_position"] - report["counts"]["updates"] < 30
    # the 0.5-m lever arm, unknown to the run, is learned as an x_icr: a warning says so
    (warning,) = [line for line in lines if line.startswith("warning:")]
    assert "antenna" in warning and "ahead of" in warning
    assert report["warnings"] == [warning.removeprefix("warning:").strip()]


def test_an_imu_offset_left_out_stops_the_run_with_one_line(logs, tmp_path, capsys):
    assert main(["run", "--wheels", str(logs / "mounted.csv"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "pose_sensor.heading_offset" in err and "--no-checks" in err


def test_mounting_with_auto_heading_offset_runs_and_records_it(logs, tmp_path, capsys):
    out = tmp_path / "out"
    args = ["run", "--wheels", str(logs / "mounted.csv"), "--out", str(out)]
    assert main([*args, "--config", str(logs / "mounted.yaml")]) == 0
    lines = capsys.readouterr().out.splitlines()
    (line,) = [line for line in lines if "pose_sensor.heading_offset:" in line]
    offset = float(line.split("(")[1].split()[0])  # "... rad (+10.1 deg), ..."
    assert offset == pytest.approx(10.0, abs=1.5) and "circular median" in line
    assert not [line for line in lines if line.startswith("warning:")]
    report = json.loads((out / "report.json").read_text())
    found = report["calibration"]["values"]["pose_sensor.heading_offset"]
    assert math.degrees(found["value"]) == pytest.approx(offset, abs=0.05)
    resolved = load_config(out / "config.yaml").pose_sensor
    assert math.degrees(float(resolved.heading_offset)) == pytest.approx(offset, abs=0.05)
    assert abs(report["final_state"]["x_icr"] - TERRAIN_TABLE["grass"].x_icr) < 0.1


def test_auto_heading_offset_of_too_short_a_log_is_one_line(tmp_path, capsys):
    log = tmp_path / "turning.csv"
    write_wheel_log(log, constant_model_log("icr", (0.42, -0.40, 0.05), seconds=10.0))
    config = tmp_path / "auto.yaml"
    config.write_text("pose_sensor: {heading_offset: auto}\n")
    args = ["run", "--wheels", str(log), "--out", str(tmp_path / "o"), "--config", str(config)]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "heading_offset auto: only" in err and "record longer" in err
