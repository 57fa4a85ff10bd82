"""Plausibility checks through the CLI: the commonest mistake on a real log stops with its cause."""

from __future__ import annotations

import pytest

from terrain_odom.cli.main import main

GRASS = "warthog_wheels_grass_2024_7_29_14h8s51.csv"


@pytest.fixture
def grass(drive_dir):
    return drive_dir / GRASS


def test_forgetting_the_config_stops_run_with_the_wheel_radius_named(grass, tmp_path, capsys):
    before = grass.read_bytes()
    out = tmp_path / "out"
    assert main(["run", "--wheels", str(grass), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err
    assert "wheel radius 0.1 m" in err and "--no-checks" in err and "(x2.87)" in err
    assert not (out / "trajectory.csv").exists()
    assert grass.read_bytes() == before


@pytest.mark.parametrize("command", ["evaluate", "fit"])
def test_evaluate_and_fit_check_too(command, grass, tmp_path, capsys):
    args = {
        "evaluate": ["evaluate", "--wheels", str(grass)],
        "fit": [
            "fit",
            "--model",
            "edd-sym",
            "--wheels",
            str(grass),
            "--out",
            str(tmp_path / "p"),
        ],
    }[command]
    assert main(args) == 2
    assert "check the wheel radius" in capsys.readouterr().err


def test_no_checks_runs_anyway(grass, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["run", "--wheels", str(grass), "--out", str(out), "--no-checks"]) == 0
    assert (out / "trajectory.csv").is_file()


def test_the_real_log_with_its_config_passes_the_checks(grass, warthog_yaml, tmp_path):
    out = tmp_path / "out"
    assert (
        main(["run", "--wheels", str(grass), "--config", str(warthog_yaml), "--out", str(out)]) == 0
    )
