"""A run folder carries its configuration: evaluate --run uses it, a disagreeing --config is refused."""

from __future__ import annotations

import json

import pytest

from terrain_odom.cli.main import main
from terrain_odom.config import load_config

GRASS = "warthog_wheels_grass_2024_7_29_14h8s51.csv"


@pytest.fixture(scope="module")
def grass_run(drive_dir, warthog_yaml, tmp_path_factory):
    log = drive_dir / GRASS
    out = tmp_path_factory.mktemp("run") / "out"
    args = ["run", "--wheels", str(log), "--config", str(warthog_yaml), "--pose-delay", "auto"]
    assert main([*args, "--out", str(out)]) == 0
    return log, out


def test_the_run_writes_the_configuration_it_used_with_the_pose_delay_resolved(
    grass_run, warthog_yaml
):
    _, out = grass_run
    used = load_config(out / "config.yaml")
    delay = json.loads((out / "report.json").read_text())["time_calibration"]["pose_delay_s"]
    assert used.time.pose_delay == pytest.approx(delay) and delay > 0.05
    assert used.robot == load_config(warthog_yaml).robot


def test_evaluate_run_without_config_uses_the_runs(grass_run, warthog_yaml, tmp_path, capsys):
    log, out = grass_run
    capsys.readouterr()
    base = ["evaluate", "--wheels", str(log), "--run", str(out)]
    assert main([*base, "--out", str(tmp_path / "a")]) == 0
    implicit = json.loads((tmp_path / "a" / "evaluation.json").read_text())
    explicit_args = ["--config", str(out / "config.yaml"), "--out", str(tmp_path / "b")]
    assert main([*base, *explicit_args]) == 0
    explicit = json.loads((tmp_path / "b" / "evaluation.json").read_text())
    assert implicit["models"] == explicit["models"]
    ekf = implicit["models"]["ekf (online)"]["translation_m_per_m"]["median"]
    assert ekf < 0.06  # the run's geometry, not the built-in 0.1 m wheel radius


def test_a_config_with_other_geometry_than_the_run_is_refused(grass_run, examples_dir, capsys):
    log, out = grass_run
    capsys.readouterr()
    args = ["evaluate", "--wheels", str(log), "--run", str(out)]
    assert main([*args, "--config", str(examples_dir / "demo.yaml")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "robot.wheel_radius 0.1 m" in err and "made with 0.3 m" in err
