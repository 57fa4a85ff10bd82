"""``terrain-odom calibrate`` and ``run`` with ``auto`` sensor values, on a degraded log."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from terrain_odom.cli.main import main
from terrain_odom.config import load_config
from terrain_odom.io.wheel_log import write_wheel_log
from terrain_odom.records import WheelLog
from terrain_odom.sim.degrade import Degradation, degrade_log
from terrain_odom.sim.model_log import constant_model_log

TRUE = Degradation(
    gps_noise=0.3,
    gps_walk=0.0,
    latency=0.4,
    antenna=(-0.8, 0.0),
    heading_offset=2.9,
    heading_wander=0.0,
    heading_noise=0.01,
    seed=0,
)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Write a degraded 10-minute log (GPS + IMU rows), a config claiming 0.05 m, bad logs."""
    root = tmp_path_factory.mktemp("calibrate")
    clean = constant_model_log("idd", [], seconds=600.0, track_width=1.0, noise=(0.0, 0.0, 0.0))
    write_wheel_log(root / "log.csv", degrade_log(clean, TRUE).log)
    (root / "robot.yaml").write_text(
        "robot: {track_width: 1.0}\nekf: {sigma_r: {x: 0.05, y: 0.05}}\n"
    )
    t = np.arange(0.0, 60.0, 0.1)
    still = np.zeros((t.size, 3))
    write_wheel_log(root / "still.csv", WheelLog(t, 0 * t, 0 * t, still, None, 0 * t.astype(int)))
    gps_only = degrade_log(clean, Degradation(imu_rate=0.0, seed=1)).log
    write_wheel_log(root / "gps_only.csv", gps_only)
    return root


def _one_line_exit_2(args, capsys) -> str:
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err
    return err


def test_calibrate_writes_the_config_with_the_values_found_and_how(files, tmp_path, capsys):
    out = tmp_path / "cal"
    args = ["calibrate", "--wheels", str(files / "log.csv"), "--config", str(files / "robot.yaml")]
    assert main([*args, "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "GPS noise 0.3" in printed and "(claimed 0.05 m): using 0.3" in printed
    cfg = load_config(out / "config.yaml")  # reads back, every value a number
    assert cfg.robot.track_width == 1.0  # the input's values kept
    assert cfg.pose_sensor.heading_offset == pytest.approx(2.9, abs=math.radians(1.0))
    assert cfg.pose_sensor.antenna_x == pytest.approx(-0.8, abs=0.15)
    assert cfg.ekf.sigma_r.x == pytest.approx(0.3, rel=0.3)
    position, heading = cfg.time.delays
    assert float(position) - float(heading) == pytest.approx(0.4, abs=0.05)
    text = (out / "config.yaml").read_text()
    (line,) = [x for x in text.splitlines() if x.strip().startswith("antenna_x:")]
    assert "# calibrated +-" in line and "least squares" in line
    report = json.loads((out / "calibration.json").read_text())
    value = report["values"]["pose_sensor.antenna_x"]
    assert value["observable"] and value["std"] > 0 and value["value"] == cfg.pose_sensor.antenna_x


def test_run_with_auto_values_calibrates_inline_and_records_it(files, tmp_path, capsys):
    config = tmp_path / "auto.yaml"
    config.write_text(
        "robot: {track_width: 1.0}\n"
        "time: {position_delay: auto, heading_delay: auto}\n"
        "pose_sensor: {antenna_x: auto, antenna_y: auto, heading_offset: auto, noise: auto}\n"
    )
    out = tmp_path / "run"
    args = ["run", "--wheels", str(files / "log.csv"), "--config", str(config), "--out", str(out)]
    assert main([*args, "--no-plots"]) == 0  # no --no-checks needed
    printed = capsys.readouterr().out
    assert "calibrated: pose_sensor.heading_offset:" in printed
    resolved = load_config(out / "config.yaml")
    assert resolved.pose_sensor.antenna_x == pytest.approx(-0.8, abs=0.15)
    assert "# calibrated" in (out / "config.yaml").read_text()
    report = json.loads((out / "report.json").read_text())
    assert report["calibration"]["values"]["pose_sensor.heading_offset"]["applied"]
    assert (
        report["time_calibration"]["heading_delay_s"] != report["time_calibration"]["pose_delay_s"]
    )


def test_positions_without_motion_are_one_line(files, tmp_path, capsys):
    err = _one_line_exit_2(
        ["calibrate", "--wheels", str(files / "still.csv"), "--out", str(tmp_path / "o")], capsys
    )
    assert "barely move" in err and "record the robot driving" in err


def test_auto_heading_offset_without_headings_is_one_line(files, tmp_path, capsys):
    config = tmp_path / "c.yaml"
    config.write_text("robot: {track_width: 1.0}\npose_sensor: {heading_offset: auto}\n")
    args = ["run", "--wheels", str(files / "gps_only.csv"), "--config", str(config)]
    err = _one_line_exit_2([*args, "--out", str(tmp_path / "o")], capsys)
    assert "heading_offset auto needs positions and headings" in err and "IMU" in err


def test_auto_antenna_on_a_straight_drive_is_one_line(tmp_path, capsys):
    t = np.arange(0.0, 300.0, 0.05)
    clean = WheelLog(
        t,
        np.ones(t.size),
        np.ones(t.size),
        np.column_stack([t, 0 * t, 0 * t]),
        None,
        np.zeros(t.size, int),
    )
    write_wheel_log(tmp_path / "straight.csv", degrade_log(clean, Degradation(seed=0)).log)
    config = tmp_path / "c.yaml"
    config.write_text("robot: {track_width: 1.0}\npose_sensor: {antenna_x: auto}\n")
    args = ["calibrate", "--wheels", str(tmp_path / "straight.csv"), "--config", str(config)]
    err = _one_line_exit_2([*args, "--out", str(tmp_path / "o")], capsys)
    assert "antenna_x auto" in err and "S-bends" in err
