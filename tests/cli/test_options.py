"""Tests of the options shared by the subcommands (:mod:`terrain_odom.cli.options`)."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from terrain_odom.cli.options import (
    add_config_option,
    add_fit_options,
    add_log_options,
    fit_arguments,
    load_config_option,
    pose_delay_line,
    print_pose_delay,
    print_pose_delays,
)
from terrain_odom.errors import ConfigError
from terrain_odom.estimation.time_offset import PoseDelayEstimate, TimeCalibration
from terrain_odom.fitting import DEFAULT_TRAINING_HORIZON, FitOptions

ESTIMATED = TimeCalibration(0.12, PoseDelayEstimate(0.12, 0.004, 1.01, 37))


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser()
    add_config_option(p, "YAML configuration")
    add_log_options(p)
    return p


def test_load_config_option_applies_the_pose_delay(tmp_path: Path) -> None:
    config = tmp_path / "c.yaml"
    config.write_text("robot: {track_width: 0.7}\ntime: {pose_delay: 0.2}\n", encoding="utf-8")

    given = load_config_option(parser().parse_args(["--config", str(config)]))
    auto = load_config_option(
        parser().parse_args(["--config", str(config), "--pose-delay", "auto"])
    )
    defaults = load_config_option(parser().parse_args(["--pose-delay", "0.05"]))

    assert (given.robot.track_width, given.time.pose_delay) == (0.7, 0.2)
    assert (auto.robot.track_width, auto.time.pose_delay) == (0.7, "auto")
    assert defaults.time.pose_delay == 0.05


def test_load_config_option_takes_a_path_and_needs_no_pose_delay(tmp_path: Path) -> None:
    config = tmp_path / "found.yaml"
    config.write_text("robot: {track_width: 0.9}\n", encoding="utf-8")
    p = argparse.ArgumentParser()
    add_config_option(p, "YAML configuration")

    assert load_config_option(p.parse_args([]), config).robot.track_width == 0.9


def test_bad_pose_delay_is_a_config_error() -> None:
    with pytest.raises(ConfigError, match="--pose-delay"):
        load_config_option(parser().parse_args(["--pose-delay", "soon"]))


def test_pose_delay_lines(capsys: pytest.CaptureFixture[str]) -> None:
    assert pose_delay_line(TimeCalibration(0.1)) == "pose delay: 0.100 s"
    assert pose_delay_line(ESTIMATED) == (
        "pose delay: 0.120 s (estimated, +-0.004 s, from 37 heading changes)"
    )
    print_pose_delay(None)
    print_pose_delay(TimeCalibration(0.0))
    print_pose_delays({"a.csv": TimeCalibration(0.0), "b.csv": TimeCalibration(0.0)})
    assert capsys.readouterr().out == ""
    print_pose_delays({"a.csv": TimeCalibration(0.0), "b.csv": ESTIMATED})
    assert capsys.readouterr().out.splitlines() == [
        "a.csv: pose delay: 0.000 s",
        f"b.csv: {pose_delay_line(ESTIMATED)}",
    ]


def test_fit_arguments() -> None:
    p = argparse.ArgumentParser()
    add_fit_options(p)

    args = fit_arguments(
        p.parse_args(["--wheels", "a.csv", "--seed", "4", "--sigma", "1", "2", "3"])
    )

    assert args["horizon"] == DEFAULT_TRAINING_HORIZON
    assert args["by_terrain"] is False
    assert args["options"] == FitOptions(seed=4, sigma=(1.0, 2.0, 3.0))
    assert args["config_path"] is None
    with pytest.raises(ConfigError, match="--popsize"):
        fit_arguments(p.parse_args(["--wheels", "a.csv", "--popsize", "2"]))


def test_no_checks_switches_the_checks_off(tmp_path: Path) -> None:
    config = tmp_path / "c.yaml"
    config.write_text("checks: {enabled: true}\n", encoding="utf-8")
    on = load_config_option(parser().parse_args(["--config", str(config)]))
    off = load_config_option(parser().parse_args(["--config", str(config), "--no-checks"]))
    assert on.checks.enabled and not off.checks.enabled
