"""``run --priors``: ICRs fitted offline seed the EKF, end to end on simulated logs."""

from __future__ import annotations

import json

import numpy as np
import pytest

from terrain_odom.cli.main import main
from terrain_odom.config import load_config
from terrain_odom.estimation.odometry import OdometryResult, run_icr_ekf
from terrain_odom.evaluation import (
    icr_twist_from_rows,
    settling_time,
    spatial_windows,
    window_errors,
)
from terrain_odom.io import read_wheel_log
from terrain_odom.io.params import read_priors
from terrain_odom.io.wheel_log import write_wheel_log
from terrain_odom.records import WheelLog
from terrain_odom.sim.model_log import constant_model_log

TRUTH = {"grass": (0.55, -0.50, 0.05, 0.93), "gravel": (0.80, -0.72, 0.15, 0.85)}
TOLERANCE = 0.05  # m: evaluation.icr_tolerance (10 %) of the default 0.5-m track width


def _one_after_another(first: WheelLog, second: WheelLog) -> WheelLog:
    """``second`` driven right after ``first``, as a new log segment."""
    dt = first.t[1] - first.t[0]
    return WheelLog(
        np.concatenate([first.t, second.t + first.t[-1] + dt]),
        np.concatenate([first.v_l, second.v_l]),
        np.concatenate([first.v_r, second.v_r]),
        np.concatenate([first.pose, second.pose]),
        np.concatenate([first.terrain, second.terrain]),  # type: ignore[list-item]
        np.concatenate([first.segment, second.segment + first.segment[-1] + 1]),
        "<sim grass then gravel>",
    )


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Priors fitted (``terrain-odom fit``) on a training log per terrain.

    And an evaluation log of other seeds: 40 s on grass, then 40 s on gravel.
    """
    folder = tmp_path_factory.mktemp("priors")
    train = []
    for seed, (terrain, truth) in enumerate(TRUTH.items(), start=1):
        train.append(folder / f"train_{terrain}.csv")
        write_wheel_log(
            train[-1],
            constant_model_log("icr-slip", truth, seconds=60.0, seed=seed, terrain=terrain),
        )
    argv = ["fit", "--model", "icr-slip", "--by-terrain", "--popsize", "8", "--out", folder]
    assert main([str(a) for a in [*argv, "--wheels", *train]]) == 0
    priors = folder / "params_icr-slip.yaml"
    grass, gravel = (
        constant_model_log("icr-slip", truth, seconds=40.0, seed=seed, terrain=terrain)
        for seed, (terrain, truth) in enumerate(TRUTH.items(), start=10)
    )
    evaluation = folder / "eval.csv"
    write_wheel_log(evaluation, _one_after_another(grass, gravel))
    return {"priors": priors, "eval": evaluation, "train": train[0]}


def _position_errors(log: WheelLog, result: OdometryResult) -> tuple[np.ndarray, np.ndarray]:
    """Start time (s) and end position error (m) of every 2-m model-odometry window."""
    windows = spatial_windows(log)
    icr = [result.states[:, result.names.index(n)] for n in ("y_l", "y_r", "x_icr", "alpha")]
    errors = window_errors(log, windows, icr_twist_from_rows(windows, *icr))
    return log.t[windows.start], errors.translation


def test_fitted_priors_reconverge_at_once_and_lower_the_odometry_error(files):
    cfg = load_config()
    log = read_wheel_log(files["eval"])
    priors = read_priors(files["priors"])
    seeded = run_icr_ekf(log, cfg, labels=log.terrain, priors=priors)
    plain = run_icr_ekf(log, cfg, labels=log.terrain)
    (change,) = seeded.changes
    assert (change.label, change.prior) == ("gravel", True)
    on_gravel = log.t >= change.t

    def settling(result: OdometryResult) -> float:
        icr = result.states[on_gravel, 3:6]
        band = [TOLERANCE] * 3
        return settling_time(log.t[on_gravel], icr, TRUTH["gravel"][:3], band, t_from=change.t)

    assert settling(seeded) == 0.0  # within 5 cm of the truth from the change on
    assert settling(plain) > 0.5
    np.testing.assert_allclose(seeded.states[0, 3:], TRUTH["grass"], atol=0.03)  # start prior
    t_start, seeded_error = _position_errors(log, seeded)
    _, plain_error = _position_errors(log, plain)
    assert seeded_error.mean() < 0.6 * plain_error.mean()  # measured 0.0068 vs 0.0148 m
    first = (t_start >= change.t) & (t_start < change.t + 10.0)  # 10 s after the change
    assert seeded_error[first].mean() < 0.4 * plain_error[first].mean()  # 0.0087 vs 0.0348


def test_run_priors_through_the_cli(files, tmp_path, capsys):
    out = tmp_path / "r"
    argv = ["run", "--wheels", files["eval"], "--out", out, "--priors", files["priors"]]
    assert main([str(a) for a in argv]) == 0, capsys.readouterr().err
    report = json.loads((out / "report.json").read_text())
    assert report["inputs"]["priors"] == str(files["priors"].resolve())
    assert [(c["label"], c["prior"]) for c in report["terrain_changes"]] == [("gravel", True)]
    assert "offline prior" in (out / "report.md").read_text()


def _one_line_error(capsys, *argv) -> str:
    """Run the command line; check it failed with one line and no traceback; return it."""
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    assert code == 2 and captured.out == "" and "Traceback" not in captured.err
    assert len(captured.err.splitlines()) == 1, captured.err
    return captured.err


@pytest.mark.parametrize(
    ("extra", "fragment"),
    [
        (["--estimator", "slip-ekf"], "--priors seeds the ICR EKF"),
        (["--no-terrain"], "per-terrain priors (grass, gravel) need terrain labels"),
    ],
)
def test_priors_the_run_cannot_use_are_one_line_errors(files, tmp_path, capsys, extra, fragment):
    argv = ["run", "--wheels", files["eval"], "--out", tmp_path, "--priors", files["priors"]]
    assert fragment in _one_line_error(capsys, *argv, *extra)


def test_bad_priors_file_is_a_one_line_error(files, tmp_path, capsys):
    edd = tmp_path / "edd.yaml"
    edd.write_text("format_version: 2\nmodel: edd-sym\nparams: {alpha: 0.9, b_hat: 1.8}\n")
    for path, fragment in (
        (edd, "edd.yaml: model 'edd-sym' has no ICR state; fit 'icr' or 'icr-slip'"),
        (tmp_path / "missing.yaml", "missing.yaml: parameter file not found"),
    ):
        argv = ["run", "--wheels", files["train"], "--out", tmp_path / "r", "--priors", path]
        assert fragment in _one_line_error(capsys, *argv)
