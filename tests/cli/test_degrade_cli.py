"""``terrain-odom degrade``: the folder it writes, and its one-line refusals."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from terrain_odom.cli.main import main
from terrain_odom.config import load_config
from terrain_odom.io.wheel_log import read_wheel_log


def _degrade(*args: str) -> int:
    return main(["degrade", *args])


def test_degrade_writes_log_truth_config_and_injected(
    tmp_path: Path, examples_dir: Path, capsys
) -> None:
    log = examples_dir / "demo_log.csv"
    out = tmp_path / "d"
    assert _degrade("--wheels", str(log), "--config", str(examples_dir / "demo.yaml"),
                    "--out", str(out), "--seed", "2", "--antenna", "0.5", "-0.2") == 0  # fmt: skip
    printed = capsys.readouterr().out
    assert "GPS fixes" in printed and str(out / "degrade.yaml") in printed
    degraded = read_wheel_log(out / "log.csv")
    truth = read_wheel_log(out / "truth.csv")
    original = read_wheel_log(log)
    np.testing.assert_allclose(truth.pose, original.pose, atol=1e-9, equal_nan=True)
    assert degraded.has_position.any() and degraded.has_yaw.any() and not degraded.has_pose.any()
    injected = yaml.safe_load((out / "degrade.yaml").read_text())
    assert (injected["antenna_x"], injected["antenna_y"], injected["seed"]) == (0.5, -0.2, 2)
    cfg = load_config(out / "config.yaml")
    assert (cfg.ekf.sigma_r.x, cfg.ekf.sigma_r.yaw) == (0.8, 0.035)  # the claims, not the truth
    assert cfg.pose_sensor.antenna_x == 0.0  # the mounting is what calibration must find


def test_degrade_refuses_a_folder_holding_its_files(
    tmp_path: Path, examples_dir: Path, capsys
) -> None:
    log = str(examples_dir / "demo_log.csv")
    out = tmp_path / "d"
    assert _degrade("--wheels", log, "--out", str(out)) == 0
    before = (out / "log.csv").read_bytes()
    assert _degrade("--wheels", log, "--out", str(out), "--seed", "5") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "already holds log.csv" in err[0]
    assert (out / "log.csv").read_bytes() == before
    assert _degrade("--wheels", log, "--out", str(out), "--seed", "5", "--overwrite") == 0
    assert (out / "log.csv").read_bytes() != before


@pytest.mark.parametrize(
    "args, message",
    [
        (["--heading-offset", "157"], "heading_offset is radians"),
        (["--gps-rate", "-1"], "gps_rate must be finite and >= 0"),
        (["--latency", "nan"], "latency must be finite"),
    ],
)
def test_bad_options_are_one_line(
    tmp_path: Path, examples_dir: Path, capsys, args, message
) -> None:
    rc = _degrade(
        "--wheels", str(examples_dir / "demo_log.csv"), "--out", str(tmp_path / "d"), *args
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and message in err[0]
    assert not (tmp_path / "d").exists()


def test_degrade_never_writes_over_its_input(tmp_path: Path, examples_dir: Path, capsys) -> None:
    log = tmp_path / "log.csv"
    log.write_bytes((examples_dir / "demo_log.csv").read_bytes())
    before = log.read_bytes()
    assert _degrade("--wheels", str(log), "--out", str(tmp_path), "--overwrite") == 2
    assert log.read_bytes() == before
    assert "log.csv" in capsys.readouterr().err
