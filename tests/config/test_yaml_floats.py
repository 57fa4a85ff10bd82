"""Issue 24: every float spelling a user writes is a number (YAML 1.1 reads some as strings)."""

from __future__ import annotations

from pathlib import Path

import pytest

from terrain_odom.config import load_config
from terrain_odom.config.loader import read_yaml


@pytest.mark.parametrize(
    ("text", "value"),
    [
        ("1.0e9", 1.0e9),  # no exponent sign: a string to PyYAML
        ("1e-300", 1e-300),  # no dot: a string to PyYAML
        ("1E5", 1e5),
        (".5e3", 500.0),
        ("-3e+2", -300.0),
        ("2.5", 2.5),
    ],
)
def test_float_spellings_are_numbers(text: str, value: float, tmp_path: Path) -> None:
    path = tmp_path / "c.yaml"
    path.write_text(f"a: {text}\n")
    assert read_yaml(path) == {"a": value}


@pytest.mark.parametrize("text", ["1e", "e5", "1.0e", "2024-01-01x", "v1e5"])
def test_what_is_no_number_stays_text(text: str, tmp_path: Path) -> None:
    path = tmp_path / "c.yaml"
    path.write_text(f"a: {text}\n")
    assert read_yaml(path) == {"a": text}


def test_a_configuration_in_exponent_notation_loads(tmp_path: Path) -> None:
    path = tmp_path / "robot.yaml"
    path.write_text("robot:\n  wheel_radius: 1.5e-1\n  track_width: 5e-1\n")
    robot = load_config(path).robot
    assert (robot.wheel_radius, robot.track_width) == (0.15, 0.5)
