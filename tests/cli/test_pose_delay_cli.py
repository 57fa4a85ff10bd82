"""``--pose-delay`` of ``run``, ``evaluate`` and ``fit``: applied, recorded, bad values rejected."""

from __future__ import annotations

import json
import re

import pytest

from terrain_odom.cli.main import main
from terrain_odom.estimation.time_offset import delay_wheel_speeds
from terrain_odom.sim.slip_scenario import feature_slip_scenario


def _write_log(path, *, turn: bool = True) -> None:
    sc = feature_slip_scenario([1.0, 0.5, 1.2, 0.3, 0.4, 0.2], duration=60.0, seed=3,
                               wheel_rate=20.0, pose_rate=10.0)  # fmt: skip
    log = sc.log
    # the wheel speeds recorded 0.2 s early: the poses then lag them by 0.2 s
    early = delay_wheel_speeds(log, -0.2)
    v_l, v_r = early.v_l, early.v_r
    if not turn:
        v_l = v_r = 0.5 * (v_l + v_r)
    lines = ["t,v_l,v_r,x,y,yaw"]
    for k in range(len(log)):
        pose = ",".join("" if v != v else repr(float(v)) for v in log.pose[k])
        lines.append(f"{float(log.t[k])!r},{float(v_l[k])!r},{float(v_r[k])!r},{pose}")
    path.write_text("\n".join(lines) + "\n")


@pytest.fixture()
def files(tmp_path):
    log, config = tmp_path / "log.csv", tmp_path / "c.yaml"
    _write_log(log)
    config.write_text("robot: {track_width: 2.46}\n")
    return tmp_path, log, config


def test_run_and_evaluate_record_the_estimated_delay(files, capsys):
    tmp, log, config = files
    out = tmp / "run"
    base = ["--config", str(config), "--pose-delay", "auto"]
    assert (
        main(["run", "--wheels", str(log), "--out", str(out), "--estimator", "slip-ekf", *base])
        == 0
    )
    shown = re.search(r"^pose delay: (\S+) s \(estimated", capsys.readouterr().out, re.M)
    assert shown and float(shown.group(1)) == pytest.approx(0.2, abs=0.05)
    timing = json.loads((out / "report.json").read_text())["time_calibration"]
    assert timing["estimated"] and timing["pose_delay_s"] == pytest.approx(0.2, abs=0.05)
    assert "pose delay:" in (out / "report.md").read_text()
    assert main(["evaluate", "--wheels", str(log), "--run", str(out), *base]) == 0
    result = json.loads((out / "evaluation.json").read_text())
    assert result["time_calibration"]["pose_delay_s"] == pytest.approx(timing["pose_delay_s"])


def test_given_delay_overrides_the_config_and_zero_changes_nothing(files):
    tmp, log, config = files
    config.write_text("robot: {track_width: 2.46}\ntime: {pose_delay: auto}\n")
    reports = {}
    for delay in ("0.15", "0"):
        out = tmp / f"run{delay}"
        args = ["run", "--wheels", str(log), "--out", str(out), "--config", str(config)]
        assert main([*args, "--pose-delay", delay]) == 0
        reports[delay] = json.loads((out / "report.json").read_text())
    assert reports["0.15"]["time_calibration"] == {"pose_delay_s": 0.15, "estimated": False}
    assert reports["0"]["time_calibration"] == {"pose_delay_s": 0.0, "estimated": False}
    assert main(["run", "--wheels", str(log), "--out", str(tmp / "plain")]) == 0
    plain = (tmp / "plain" / "trajectory.csv").read_text()
    config.write_text("robot: {track_width: 2.46}\n")
    assert main(["run", "--wheels", str(log), "--out", str(tmp / "zero"), "--pose-delay", "0"]) == 0
    assert (tmp / "zero" / "trajectory.csv").read_text() == plain


@pytest.mark.parametrize(
    ("command", "value", "message"),
    [
        ("run", "later", "--pose-delay: must be auto or seconds, got 'later'"),
        ("evaluate", "12", "--pose-delay: 12 s is not a stamp delay"),
        ("fit", "inf", "--pose-delay: must be auto or finite seconds"),
    ],
)
def test_bad_pose_delay_is_a_one_line_error(files, capsys, command, value, message):
    tmp, log, _ = files
    args = {
        "run": ["--wheels", str(log), "--out", str(tmp / "r")],
        "evaluate": ["--wheels", str(log)],
        "fit": ["--wheels", str(log), "--model", "idd", "--out", str(tmp / "p")],
    }[command]
    code = main([command, *args, "--pose-delay", value])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and message in err and "Traceback" not in err


def test_auto_on_a_log_without_turning_is_a_one_line_error(tmp_path, capsys):
    log = tmp_path / "log.csv"
    _write_log(log, turn=False)
    code = main(["run", "--wheels", str(log), "--out", str(tmp_path / "r"), "--pose-delay", "auto"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "turning" in err


def test_fit_applies_the_delay_to_every_log(files, capsys):
    tmp, log, config = files
    args = ["fit", "--wheels", str(log), "--model", "icr", "--out", str(tmp / "p")]
    assert main([*args, "--config", str(config), "--pose-delay", "auto", "--popsize", "5",
                 "--maxiter", "5"]) == 0  # fmt: skip
    shown = re.search(
        rf"^{re.escape(str(log))}: pose delay: (\S+) s", capsys.readouterr().out, re.M
    )
    assert shown and float(shown.group(1)) == pytest.approx(0.2, abs=0.05)
