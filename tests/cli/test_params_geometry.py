"""Parameter and prior files record the robot geometry they were fitted with; other geometry is refused."""

from __future__ import annotations

import pytest
import yaml

from terrain_odom.cli.main import main


@pytest.fixture(scope="module")
def icr_params(examples_dir, tmp_path_factory):
    """Return the --out folder of a fit: params_icr.yaml (a folder run and evaluate take)."""
    out = tmp_path_factory.mktemp("fit")
    args = ["fit", "--model", "icr", "--wheels", str(examples_dir / "demo_log.csv")]
    args += ["--config", str(examples_dir / "demo.yaml"), "--maxiter", "30", "--out", str(out)]
    assert main(args) == 0
    return out


def test_the_file_records_wheel_radius_track_width_and_pose_delay(icr_params):
    data = yaml.safe_load((icr_params / "params_icr.yaml").read_text())
    assert data["wheel_radius"] == 0.1 and data["track_width"] == 0.5 and data["pose_delay"] == 0.0


def test_priors_with_another_track_width_are_refused(
    icr_params, examples_dir, warthog_yaml, tmp_path, capsys
):
    capsys.readouterr()
    args = ["run", "--wheels", str(examples_dir / "demo_log.csv"), "--config", str(warthog_yaml)]
    assert main([*args, "--priors", str(icr_params), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "robot.wheel_radius 0.1 m" in err and "says 0.3 m" in err
    assert not (tmp_path / "o" / "trajectory.csv").exists()


def test_evaluate_params_with_another_geometry_is_refused(
    icr_params, examples_dir, warthog_yaml, capsys
):
    capsys.readouterr()
    args = ["evaluate", "--wheels", str(examples_dir / "demo_log.csv"), "--params", str(icr_params)]
    assert main([*args, "--config", str(warthog_yaml)]) == 2
    assert "fitted with robot.wheel_radius 0.1 m" in capsys.readouterr().err
    assert main([*args, "--config", str(examples_dir / "demo.yaml")]) == 0


def test_prior_terrains_the_run_never_meets_are_reported(examples_dir, tmp_path, capsys):
    demo, config = examples_dir / "demo_log.csv", str(examples_dir / "demo.yaml")
    priors = tmp_path / "priors"
    fit = ["fit", "--model", "icr", "--by-terrain", "--wheels", str(demo), "--config", config]
    assert main([*fit, "--maxiter", "20", "--out", str(priors)]) == 0
    grass_only = tmp_path / "grass.csv"  # the demo's first 45 s: grass
    grass_only.write_text("".join(demo.read_text().splitlines(True)[:901]))
    capsys.readouterr()
    run = ["run", "--wheels", str(grass_only), "--config", config, "--priors", str(priors)]
    assert main([*run, "--out", str(tmp_path / "out")]) == 0
    assert "priors never used: gravel (no such terrain in this run)" in capsys.readouterr().out
