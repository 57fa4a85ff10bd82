"""``terrain-odom run --estimator slip-ekf`` and ``evaluate`` on its output."""

from __future__ import annotations

import csv
import json

import numpy as np

from terrain_odom.cli.main import main
from terrain_odom.sim.slip_scenario import feature_slip_scenario


def _write_log(path, *, heading_only: bool = False, no_yaw: bool = False) -> None:
    log = feature_slip_scenario([1.0, 0.5, 1.2, 0.3, 0.4, 0.2], duration=40.0, seed=3).log
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["t", "v_l", "v_r", "x", "y", "yaw"])
        for t, v_l, v_r, (x, y, yaw) in zip(log.t, log.v_l, log.v_r, log.pose, strict=True):
            cells = [x, y, np.nan if no_yaw else yaw]
            if heading_only:
                cells[:2] = [np.nan, np.nan]
            writer.writerow([t, v_l, v_r, *("" if np.isnan(c) else repr(float(c)) for c in cells)])


def test_run_slip_ekf_then_evaluate(tmp_path, capsys):
    log, out = tmp_path / "log.csv", tmp_path / "run"
    config = tmp_path / "c.yaml"
    config.write_text("robot: {track_width: 2.46}\nslip_ekf: {estimate_alpha: false}\n")
    _write_log(log)
    args = ["--wheels", str(log), "--out", str(out), "--config", str(config)]
    assert main(["run", *args, "--estimator", "slip-ekf"]) == 0
    header = (out / "trajectory.csv").read_text().splitlines()[0].split(",")
    assert header[:8] == ["t", "x", "y", "yaw", "y_l", "y_r", "x_icr", "terrain"]
    assert "l6" in header and "std_l1" in header
    assert json.loads((out / "report.json").read_text())["estimator"] == "slip-ekf"
    assert main(["evaluate", "--wheels", str(log), "--run", str(out), "--config", str(config)]) == 0
    text = capsys.readouterr().out
    assert "slip-ekf (online)" in text and "2-s prediction" in text
    result = json.loads((out / "evaluation.json").read_text())["prediction_2s"]["models"]
    slip, idd = result["slip-ekf (online)"], result["idd (B=2.46 m)"]
    assert slip["position_m"] < 0.5 * idd["position_m"]


def test_heading_only_log_runs(tmp_path):
    log = tmp_path / "log.csv"
    _write_log(log, heading_only=True)
    assert (
        main(["run", "--wheels", str(log), "--out", str(tmp_path / "r"), "--estimator", "slip-ekf"])
        == 0
    )


def test_slip_ekf_without_yaw_runs_on_the_positions(tmp_path, capsys):
    log = tmp_path / "log.csv"
    _write_log(log, no_yaw=True)
    code = main(
        ["run", "--wheels", str(log), "--out", str(tmp_path / "r"), "--estimator", "slip-ekf"]
    )
    assert code == 0
    (pose,) = [line for line in capsys.readouterr().out.splitlines() if line.startswith("pose:")]
    assert "heading 0 of 0" in pose
