"""Tests of the typed results of ``fit`` and ``compare`` (:mod:`terrain_odom.app.fit`)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

from terrain_odom.app.fit import CompareReport, FitEvaluation, FitReport, compare, fit
from terrain_odom.app.simulate import SimOutput
from terrain_odom.estimation.time_offset import TimeCalibration
from terrain_odom.evaluation import ErrorSummary
from terrain_odom.fitting import FitOptions, FitResult
from terrain_odom.fitting.params import ANY_TERRAIN
from terrain_odom.io.params import read_params

FAST = FitOptions(popsize=5, maxiter=3, seed=0)


@pytest.fixture(scope="module")
def fitted(
    sim_output: SimOutput, tmp_path_factory: pytest.TempPathFactory
) -> tuple[FitReport, Path]:
    out = tmp_path_factory.mktemp("fit") / "params.yaml"
    log = sim_output.log_csv
    report = fit([log], "edd-sym", out_dir=out, eval_logs=[log], by_terrain=True, options=FAST)
    return report, out


@pytest.fixture(scope="module")
def compared(
    sim_output: SimOutput, tmp_path_factory: pytest.TempPathFactory
) -> tuple[CompareReport, Path]:
    out = tmp_path_factory.mktemp("compare")
    log = sim_output.log_csv
    return compare([log], [log], out_dir=out, models=["idd", "icr"], options=FAST), out


def test_fit_report(fitted: tuple[FitReport, Path], sim_output: SimOutput) -> None:
    report, _ = fitted
    assert list(report.fits) == list(report.params.sets) == ["grass", "gravel"]
    assert all(isinstance(f, FitResult) for f in report.fits.values())
    assert report.seconds == {k: f.seconds for k, f in report.fits.items()}
    assert report.skipped == ()
    assert list(report.time_calibration.values()) == [TimeCalibration(0.0)]
    for terrain, ps in report.params.sets.items():
        assert ps.fit["segments"] == report.fits[terrain].segments
    with pytest.raises(dataclasses.FrozenInstanceError):
        report.skipped = ("grass",)  # type: ignore[misc]  # the assignment under test


def test_fit_evaluation_is_what_the_parameter_file_holds(fitted: tuple[FitReport, Path]) -> None:
    report, out = fitted
    ev = report.evaluation
    assert isinstance(ev, FitEvaluation)
    assert ev.horizon == 2.0
    assert len(ev.logs) == 1
    assert sorted(ev.groups) == ["grass", "gravel"]
    for models in ev.groups.values():
        assert list(models) == ["edd-sym", "idd (B=0.5 m)"]
        assert all(isinstance(s, ErrorSummary) for s in models.values())
    assert read_params(out).info["evaluation"] == json.loads(json.dumps(ev.to_dict()))


def test_fit_without_eval_logs_has_no_evaluation(sim_output: SimOutput) -> None:
    report = fit([sim_output.log_csv], "idd", options=FAST)

    assert report.evaluation is None
    assert "evaluation" not in report.params.info


def test_compare_to_dict_is_what_compare_json_holds(
    compared: tuple[CompareReport, Path],
) -> None:
    report, out = compared
    on_disk = json.loads((out / "compare.json").read_text(encoding="utf-8"))

    assert on_disk == json.loads(json.dumps(report.to_dict()))
    assert on_disk["command"] == "compare"
    assert list(on_disk["models"]) == ["idd", "icr"]
    assert set(on_disk["models"]["icr"]) == {"sets", "derived", "skipped_terrains", "errors"}
    assert (out / "compare.md").read_text(encoding="utf-8") == report.markdown


def test_compare_attributes(compared: tuple[CompareReport, Path]) -> None:
    report, out = compared
    assert report.training_logs == report.evaluation_logs
    assert str(report.horizon_train) == "2m"
    assert report.horizon_eval == 2.0
    assert report.track_width == 0.5
    icr = report.models["icr"]
    assert icr.params.model == "icr"
    assert read_params(out / "params_icr.yaml").sets == icr.params.sets
    assert list(icr.errors) == [ANY_TERRAIN]  # written "all" (compare.json)
    assert icr.errors[ANY_TERRAIN].translation.count > 0
    assert "| icr | all |" in report.markdown
