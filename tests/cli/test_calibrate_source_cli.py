"""``terrain-odom calibrate`` names the robot geometry it calibrated with, and where it came from."""

from __future__ import annotations

from pathlib import Path

import pytest

from terrain_odom.cli.main import main
from terrain_odom.io.wheel_log import write_wheel_log
from terrain_odom.sim.degrade import Degradation, degrade_log
from terrain_odom.sim.model_log import constant_model_log


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Write a 3-minute GPS + IMU log of a robot with a 1-m track and its configuration beside it."""
    root = tmp_path_factory.mktemp("source")
    clean = constant_model_log("idd", [], seconds=180.0, track_width=1.0, noise=(0.0, 0.0, 0.0))
    write_wheel_log(root / "log.csv", degrade_log(clean, Degradation(seed=0)).log)
    (root / "robot.yaml").write_text("robot: {track_width: 1.0, wheel_radius: 0.2}\n")
    return root / "log.csv"


def _first_line(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    assert main(argv) == 0
    return capsys.readouterr().out.splitlines()[0]


def test_without_config_the_built_in_robot_is_named(
    log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A 0.5-m track completed on a 1-m robot's log: the console says whose geometry it is."""
    argv = ["calibrate", "--wheels", str(log), "--out", str(tmp_path / "cal")]
    assert _first_line(argv, capsys) == (
        "robot:      wheel radius 0.1 m, track width 0.5 m "
        "(the built-in defaults: --config gives the robot's)"
    )


def test_with_config_its_geometry_and_file_are_named(
    log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = log.parent / "robot.yaml"
    argv = ["calibrate", "--wheels", str(log), "--config", str(config)]
    first = _first_line([*argv, "--out", str(tmp_path / "cal")], capsys)
    assert first == f"robot:      wheel radius 0.2 m, track width 1 m (from {config})"


def test_an_imported_configuration_is_used_unless_config_is_given(
    log: Path, tmp_path: Path
) -> None:
    """The app chooses (not the CLI): a bag import's configuration, else ``--config`` first."""
    from terrain_odom.app.calibrate import calibrate

    imported = tmp_path / "imported.yaml"
    imported.write_text("robot: {track_width: 0.9, wheel_radius: 0.2}\n")
    chosen = calibrate(log, tmp_path / "a", imported=imported)
    assert (chosen.config_path, chosen.robot.track_width) == (imported, 0.9)
    given = log.parent / "robot.yaml"
    wins = calibrate(log, tmp_path / "b", config_path=given, imported=imported)
    assert (wins.config_path, wins.robot.track_width) == (given, 1.0)


def test_a_config_without_a_robot_section_is_not_called_the_robots(
    log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A --config file that sets only other sections: its geometry is the built-in one, and said so."""
    config = tmp_path / "other.yaml"
    config.write_text("ekf: {gate: {probability: 0.999}}\n")
    argv = [
        "calibrate",
        "--wheels",
        str(log),
        "--config",
        str(config),
        "--out",
        str(tmp_path / "c"),
    ]
    assert _first_line(argv, capsys) == (
        "robot:      wheel radius 0.1 m, track width 0.5 m "
        f"(the built-in defaults: {config} gives no other)"
    )
