"""``evaluate`` on GPS and IMU rows, ``evaluate --outage`` and ``run``'s outage guard, as a user runs them."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from terrain_odom.cli.main import main
from terrain_odom.io.wheel_log import write_wheel_log
from terrain_odom.records import WheelLog


@pytest.fixture(scope="module")
def logs(tmp_path_factory, recording):
    """90 s on gravel: GPS fixes of an antenna 0.5 m behind (0.3 m, 2.5 Hz), IMU headings 10 deg off.

    ``gps_imu.csv``: positions and headings on different rows; ``gps.csv``:
    the fixes alone; ``imu.csv``: the headings alone; ``wheels.csv``: no pose.
    """
    sim = recording(
        90.0,
        seed=4,
        scenario="mixed",
        terrain="gravel",
        pose_rate=5.0,
        sigma_xy=0.3,
        antenna=(-0.5, 0.0),
        heading_offset=math.radians(10.0),
    ).sim
    folder = tmp_path_factory.mktemp("outage")
    n = sim.motion.t.size
    pose = sim.measured_pose.copy()
    rows = np.flatnonzero(np.isfinite(pose[:, 0]))
    gps, imu = rows[::2], rows[1::2]  # alternate: 2.5-Hz fixes, 2.5-Hz headings
    pose[gps, 2] = np.nan
    pose[imu, :2] = np.nan
    log = WheelLog(sim.motion.t, sim.v_l, sim.v_r, pose, None, np.zeros(n, int), "<sim>")
    write_wheel_log(folder / "gps_imu.csv", log)
    only = {"gps": np.where(np.isfinite(pose[:, 2:]), np.nan, pose)}
    only["imu"] = np.where(np.isfinite(pose[:, :1]), np.nan, pose)
    only["wheels"] = np.full_like(pose, np.nan)
    for name, p in only.items():
        write_wheel_log(folder / f"{name}.csv", dataclasses.replace(log, pose=p))
    (folder / "config.yaml").write_text(
        "robot: {wheel_radius: 0.1, track_width: 0.5}\n"
        "ekf: {sigma_r: {x: 0.3, y: 0.3, yaw: 0.02}}\n"
        "pose_sensor: {antenna_x: -0.5, heading_offset: 0.17453292519943295}\n"
        "checks: {enabled: false}\n"
    )
    return folder


def _evaluate(args, capsys):
    code = main(["evaluate", *args])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_positions_and_headings_on_different_rows_are_scored_and_labelled(logs, tmp_path, capsys):
    out = tmp_path / "eval"
    code, printed, _ = _evaluate(
        ["--wheels", str(logs / "gps_imu.csv"), "--config", str(logs / "config.yaml"),
         "--out", str(out), "--horizon", "3m"],
        capsys,
    )  # fmt: skip
    assert code == 0
    assert "windows:    between position fixes, length from the wheels" in printed
    report = json.loads((out / "evaluation.json").read_text())
    assert report["windows_between"] == "position"
    idd = report["models"]["idd (B=0.5 m)"]
    assert idd["rotation_deg_per_m"]["count"] == report["windows"] > 20  # headings near every fix
    assert idd["translation_m_per_m"]["median"] > 0.0
    assert idd["ate_dead_reckoning"]["rmse_m"] is None  # no full pose: no ATE
    assert "outages" not in report  # outages need a run
    for name in ("evaluation_windows.png", "evaluation_boxes.png"):
        assert (out / "plots" / name).stat().st_size > 10_000


def test_fixes_alone_and_headings_alone(logs, tmp_path, capsys):
    cfg = ["--config", str(logs / "config.yaml"), "--horizon", "3m"]
    out = ["--out", str(tmp_path / "gps")]  # plots with a column of nothing measured
    code, printed, _ = _evaluate(["--wheels", str(logs / "gps.csv"), *cfg, *out], capsys)
    assert code == 0 and "between position fixes" in printed
    assert (tmp_path / "gps" / "plots" / "evaluation_boxes.png").stat().st_size > 10_000
    idd = [line for line in printed.splitlines() if line.startswith("idd")][0]  # the table's
    assert idd.split()[5] == "n/a"  # no heading error without headings
    out = ["--out", str(tmp_path / "imu")]
    code, printed, _ = _evaluate(["--wheels", str(logs / "imu.csv"), *cfg, *out], capsys)
    assert code == 0 and "between heading rows (length from the wheels" in printed
    assert (tmp_path / "imu" / "plots" / "evaluation_windows.png").stat().st_size > 10_000
    code, _, err = _evaluate(["--wheels", str(logs / "wheels.csv"), *cfg], capsys)
    assert code == 2 and err.count("\n") == 1 and "no pose measurements (x, y or yaw)" in err


@pytest.fixture(scope="module")
def run_dir(logs, tmp_path_factory):
    out = tmp_path_factory.mktemp("run") / "run"
    args = ["run", "--wheels", str(logs / "gps_imu.csv"), "--config", str(logs / "config.yaml")]
    assert main([*args, "--out", str(out), "--no-plots"]) == 0
    return out


def test_the_run_guards_its_learned_model_on_outages(run_dir, logs, capsys):
    report = json.loads((run_dir / "report.json").read_text())
    guard = report["outage_guard"]
    assert set(guard["durations"]) == {"30", "60"}
    assert guard["durations"]["30"]["windows"] == 7  # starts 0-60 s: the last ends by 89.8 s
    models = guard["durations"]["30"]["models"]
    assert set(models) == {"learned", "nominal", "idd"}
    learned = models["learned"]["position_m"]["median"]
    assert learned < models["idd"]["position_m"]["median"]  # gravel skids: idd is far off
    assert (learned > models["nominal"]["position_m"]["median"]) == bool(guard["learned_worse_s"])
    assert "## Outage guard" in (run_dir / "report.md").read_text()


def test_wheel_only_runs_say_why_there_is_no_guard(logs, tmp_path, capsys):
    out = tmp_path / "wheels"
    args = ["run", "--wheels", str(logs / "wheels.csv"), "--config", str(logs / "config.yaml")]
    assert main([*args, "--out", str(out), "--no-plots"]) == 0
    printed = capsys.readouterr().out
    assert "outages:    skipped: no position measurements in the log" in printed
    report = json.loads((out / "report.json").read_text())
    assert report["outage_guard"]["skipped"].startswith("no position measurements")


def test_evaluate_a_sparse_run_scores_outages_by_default(run_dir, logs, capsys):
    code, printed, _ = _evaluate(
        ["--run", str(run_dir), "--wheels", str(logs / "gps_imu.csv"), "--horizon", "3m"], capsys
    )
    assert code == 0
    assert "outage windows: each model dead-reckoned from the run's state" in printed
    report = json.loads((run_dir / "evaluation.json").read_text())
    entry = report["outages"]["durations"]["30"]
    assert set(entry["models"]) == {"idd (B=0.5 m)", "ekf (online)"}
    assert entry["models"]["ekf (online)"]["heading_deg"]["count"] == entry["windows"]
    assert (run_dir / "plots" / "evaluation_outages.png").stat().st_size > 10_000
    code, printed, _ = _evaluate(
        ["--run", str(run_dir), "--wheels", str(logs / "gps_imu.csv"), "--horizon", "3m",
         "--outage", "off"],
        capsys,
    )  # fmt: skip
    assert code == 0 and "outage windows" not in printed
    assert "outages" not in json.loads((run_dir / "evaluation.json").read_text())


@pytest.mark.parametrize(
    ("values", "message"),
    [
        (["2m"], "--outage: '2m' is not a duration like 30s"),
        (["-5"], "--outage: '-5' is not a duration"),
        (["0s"], "--outage: '0s' is not a duration"),
        (["nan"], "--outage: 'nan' is not a duration"),
        (["30s", "off"], "--outage: 'off' is not a duration"),
        (["1000s"], "--outage 1000s: no outage window of"),
        (["1e-9s"], "--outage: '1e-9s' is shorter than 1 s"),
    ],
)
def test_bad_outage_values_are_one_line(run_dir, logs, capsys, values, message):
    args = ["--run", str(run_dir), "--wheels", str(logs / "gps_imu.csv"), "--outage", *values]
    code, _, err = _evaluate(args, capsys)
    assert code == 2
    assert err.count("\n") == 1 and message in err


def test_outage_without_a_run_is_one_line(logs, capsys):
    args = ["--wheels", str(logs / "gps_imu.csv"), "--config", str(logs / "config.yaml")]
    code, _, err = _evaluate([*args, "--outage", "30s"], capsys)
    assert code == 2 and err.count("\n") == 1 and "give --run" in err
