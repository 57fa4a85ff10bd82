"""A run with ``pose_sensor.heading_bias``: the bias is reported where the other states are."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from terrain_odom.app.run import RunOptions, run
from terrain_odom.errors import ConfigError
from terrain_odom.kinematics import integrate, twist_icr, wrap_angle


def test_the_heading_bias_is_in_the_trajectory_and_the_report(tmp_path: Path) -> None:
    """Arcs with positions every 5th row and headings 0.2 rad off on the others."""
    t = np.arange(600) / 20.0
    v_l = 0.9 + 0.4 * np.sin(2.0 * np.pi * t / 8.0)
    v_r = 1.1 - 0.4 * np.sin(2.0 * np.pi * t / 8.0)
    poses = integrate(*twist_icr(v_l[:-1], v_r[:-1], 0.6, -0.55, 0.0), np.diff(t), start=[0, 0, 0])
    path = tmp_path / "log.csv"
    with open(path, "w", encoding="utf-8", newline="") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(["t", "v_l", "v_r", "x", "y", "yaw"])
        for k in range(t.size):
            x, y, yaw = poses[k]
            row = [x, y, ""] if k % 5 == 0 else ["", "", wrap_angle(yaw + 0.2)]
            writer.writerow([t[k], v_l[k], v_r[k], *row])
    config = tmp_path / "bias.yaml"
    config.write_text(
        "robot: {track_width: 1.0}\npose_sensor: {heading_bias: true, heading_wander: 0.3}\n",
        encoding="utf-8",
    )
    summary = run(
        path, tmp_path / "out", RunOptions(config_path=config, progress=False, plots=False)
    )
    header = summary.trajectory_csv.read_text(encoding="utf-8").splitlines()[0].split(",")
    assert header[-1] == "std_heading_bias" and "heading_bias" in header
    report = json.loads(summary.report_json.read_text(encoding="utf-8"))
    bias, std = report["final_state"]["heading_bias"], report["final_std"]["heading_bias"]
    assert abs(bias - 0.2) < 0.05 and std < 0.1  # the constant 0.2-rad offset, found
    assert report["config"]["pose_sensor"]["heading_bias"] is True


def test_headings_without_positions_refuse_the_heading_bias(tmp_path: Path) -> None:
    """Only a course tells a heading's slow bias from the yaw: one line naming the log and key."""
    path = tmp_path / "imu.csv"
    rows = "".join(f"{0.05 * k:.2f},1.0,1.2,,,{0.01 * k:.3f}\n" for k in range(200))
    path.write_text("t,v_l,v_r,x,y,yaw\n" + rows, encoding="utf-8")
    config = tmp_path / "bias.yaml"
    config.write_text("pose_sensor: {heading_bias: true}\n", encoding="utf-8")
    with pytest.raises(ConfigError, match="headings but no positions: pose_sensor.heading_bias"):
        run(path, tmp_path / "out", RunOptions(config_path=config, progress=False, plots=False))
    assert not (tmp_path / "out" / "trajectory.csv").exists()
