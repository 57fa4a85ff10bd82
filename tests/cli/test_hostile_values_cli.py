"""Issue 24: values that used to end in a traceback or in silence, each one line and exit 2."""

from __future__ import annotations

from pathlib import Path

import pytest

from terrain_odom.cli.main import main


def _one_line(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("terrain-odom: error: "), err
    return err


@pytest.mark.parametrize("duration", ["1e12", "1e300", "360000"])
def test_simulate_duration_is_bounded_by_memory(
    duration: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    err = _one_line(["simulate", "--duration", duration, "--out", str(tmp_path / "s")], capsys)
    assert "a simulation holds in memory: at most 27.8 h" in err
    assert not (tmp_path / "s").exists()


def test_simulate_longer_than_the_map_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["simulate", "--duration", "600", "--no-frames", "--no-patches"]
    err = _one_line([*argv, "--out", str(tmp_path / "s")], capsys)
    assert "the robot leaves the scenario's map at t = 78.48 s" in err
    assert not (tmp_path / "s").exists()
