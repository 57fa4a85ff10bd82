"""Tests of configuration loading and validation."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import pytest

from terrain_odom.config import (
    SIGNED,
    Config,
    IcrSigmas,
    PoseSensorConfig,
    build_section,
    load_config,
    with_pose_delay,
)
from terrain_odom.errors import ConfigError

REPO = Path(__file__).resolve().parents[2]


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "cfg.yaml"
    path.write_text(text)
    return path


def test_default_yaml_equals_builtin_defaults():
    assert load_config(REPO / "config" / "default.yaml") == Config()
    assert load_config(None) == Config()


def test_every_shipped_config_loads():
    for path in sorted((REPO / "config").glob("*.yaml")):
        if path.name.startswith("grid_"):  # --grid files (tests/vision/test_small_patches.py)
            continue
        cfg = load_config(path)
        initial = cfg.ekf.initial.resolve(cfg.robot)
        assert initial.y_l > 0 > initial.y_r, path


def test_warthog_geometry():
    cfg = load_config(REPO / "config" / "warthog.yaml")
    assert (cfg.robot.wheel_radius, cfg.robot.track_width) == (0.30, 1.08)


def test_partial_file_keeps_other_defaults(tmp_path):
    cfg = load_config(_write(tmp_path, "ekf:\n  sigma_q: {x: 0.3}\n"))
    assert cfg.ekf.sigma_q.x == 0.3
    assert cfg.ekf.sigma_q.y == Config().ekf.sigma_q.y  # not the class default of the dataclass
    assert cfg.robot == Config().robot


def test_per_terrain_pb_falls_back_to_sigma_pb(tmp_path):
    text = "ekf:\n  sigma_pb_per_terrain: {sand: {y_l: 2.0}}\n  sigma_pb: {y_r: 0.7}\n"
    cfg = load_config(_write(tmp_path, text))
    assert cfg.ekf.sigma_pb_per_terrain["sand"] == IcrSigmas(2.0, 0.7, 0.5, 0.1)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("robot:\n  wheel_radus: 0.3\n", r"cfg\.yaml: robot: unknown key\(s\) \['wheel_radus'\]"),
        ("ekf:\n  sigma_r: {x: -0.1}\n", r"ekf\.sigma_r\.x: must be > 0, got -0\.1"),
        ("ekf:\n  sigma_q: {x: -0.1}\n", r"ekf\.sigma_q\.x: must be >= 0"),
        ("ekf:\n  sigma_prior: {y_l: 0}\n", r"ekf\.sigma_prior\.y_l: must be > 0, got 0"),
        ("ekf:\n  sigma_r: {x: abc}\n", r"ekf\.sigma_r\.x: must be a number, got 'abc'"),
        ("ekf:\n  sigma_r: {x: .nan}\n", r"ekf\.sigma_r\.x: must be finite"),
        ("ekf:\n  estimate_alpha: 1\n", r"ekf\.estimate_alpha: must be true or false"),
        ("terrain:\n  confirm: 0\n", r"terrain\.confirm: must be a whole number >= 1"),
        ("ekf:\n  initial: {y_l: -0.2, y_r: 0.2}\n", r"ekf\.initial\.y_l: must be > 0"),
        ("ekf:\n  initial: {y_r: 0.2}\n", r"ekf\.initial needs y_l > 0 > y_r"),
        ("ekf:\n  initial: {alpha: 2.0}\n", r"alpha must lie in \[alpha_min, alpha_max\]"),
        ("format_version: 2\n", r"format_version 2 is not supported"),
        ("time: {pose_delay: soon}\n", r"time\.pose_delay: must be a finite number or 'auto'"),
        ("time: {pose_delay: .inf}\n", r"time\.pose_delay: must be a finite number or 'auto'"),
        ("time: {pose_delay: 200}\n", r"time\.pose_delay: 200 s is not a stamp delay"),
        ("pose_sensor: {heading_offset: 10}\n", r"heading_offset: 10 is not an angle in radians"),
        ("pose_sensor: {heading_offset: maybe}\n", r"heading_offset: must be a finite number"),
        ("pose_sensor: {antenna_x: 50}\n", r"pose_sensor\.antenna_x: 50 m is not an antenna"),
        ("pose_sensor: {lever: 0.5}\n", r"pose_sensor: unknown key\(s\) \['lever'\]"),
        ("robot: 3\n", r"robot: expected a mapping"),
        ("robot: [\n", r"line \d+: not valid YAML"),
    ],
)
def test_invalid_config_names_file_and_key(tmp_path, text, message):
    with pytest.raises(ConfigError, match=message) as info:
        load_config(_write(tmp_path, text))
    assert "cfg.yaml" in str(info.value)
    assert "\n" not in str(info.value)


def test_pose_sensor_from_file(tmp_path):
    assert Config().pose_sensor == PoseSensorConfig(0.0, 0.0, 0.0)
    text = "pose_sensor: {antenna_x: -0.4, antenna_y: 0.1, heading_offset: auto}\n"
    assert load_config(_write(tmp_path, text)).pose_sensor == PoseSensorConfig(-0.4, 0.1, "auto")
    text = "pose_sensor: {heading_offset: -0.17}\n"
    assert load_config(_write(tmp_path, text)).pose_sensor.heading_offset == -0.17


@pytest.mark.parametrize(("text", "value"), [("auto", "auto"), ("0.15", 0.15), ("-0.2", -0.2)])
def test_pose_delay_from_file_and_command_line(tmp_path, text, value):
    assert Config().time.pose_delay == 0.0
    assert load_config(_write(tmp_path, f"time: {{pose_delay: {text}}}\n")).time.pose_delay == value
    assert with_pose_delay(Config(), text).time.pose_delay == value
    assert with_pose_delay(Config(), None) == Config()


@pytest.mark.parametrize(
    ("text", "message"),
    [("x", "must be auto or seconds, got 'x'"), ("nan", "finite"), ("-7", "not a stamp delay")],
)
def test_bad_pose_delay_option(text, message):
    with pytest.raises(ConfigError, match=f"--pose-delay: .*{message}"):
        with_pose_delay(Config(), text)


def test_missing_config_file(tmp_path):
    with pytest.raises(ConfigError, match="config file not found"):
        load_config(tmp_path / "nope.yaml")


@dataclass(frozen=True)
class _Section:
    mode: Literal["a", "b"] = "a"
    matrix: tuple[float, ...] | None = field(default=None, metadata=SIGNED)
    offset: float = field(default=0.0, metadata=SIGNED)
    size: float = 1.0


def test_build_section_validates_choices_optional_tuples_and_signs():
    Section = _Section  # noqa: N806
    ok = build_section(Section(), {"mode": "b", "matrix": [1, -2.5, 3], "offset": -0.3})
    assert ok == Section("b", (1.0, -2.5, 3.0), -0.3, 1.0)
    assert build_section(Section(), {"matrix": None}).matrix is None
    for data, message in [
        ({"mode": "c"}, r"cam\.mode: must be one of \['a', 'b'\], got 'c'"),
        ({"matrix": [1, "x"]}, r"cam\.matrix\[1\]: must be a number"),
        ({"matrix": 3}, r"cam\.matrix: must be a list of numbers"),
        ({"size": -1.0}, r"cam\.size: must be > 0"),
    ]:
        with pytest.raises(ConfigError, match=message):
            build_section(Section(), data, "cam")
