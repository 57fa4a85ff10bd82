"""Tests of :class:`terrain_odom.app.evaluation_results.EvaluationResult` (the typed result of ``evaluate``)."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import pytest

from terrain_odom.app.evaluate import evaluate
from terrain_odom.app.evaluation_results import EvaluationResult, ModelErrors
from terrain_odom.app.simulate import SimOutput
from terrain_odom.config import Config, TimeConfig


@pytest.fixture(scope="module")
def written(sim_output: SimOutput, tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("evaluate") / "evaluation.json"


@pytest.fixture(scope="module")
def result(sim_output: SimOutput, written: Path) -> EvaluationResult:
    return evaluate(None, sim_output.log_csv, horizon=1.0, out_dir=written)


def test_to_dict_is_what_evaluation_json_holds(result: EvaluationResult, written: Path) -> None:
    on_disk = json.loads(written.read_text(encoding="utf-8"))

    assert on_disk == json.loads(json.dumps(result.to_dict()))
    assert on_disk["command"] == "evaluate"
    assert on_disk["run"] is None
    assert on_disk["horizon_m"] == 1.0
    assert on_disk["windows"] == result.windows > 0
    assert on_disk["prediction_2s"]["windows"] == result.prediction_windows
    assert on_disk["time_calibration"] == {"pose_delay_s": 0.0, "estimated": False}


def test_attributes(result: EvaluationResult, sim_output: SimOutput) -> None:
    assert result.log == sim_output.log_csv.resolve()
    assert result.run is None
    assert result.time_calibration.pose_delay == 0.0
    assert list(result.models) == list(result.prediction) == ["idd (B=0.5 m)"]
    entry = result.models["idd (B=0.5 m)"]
    assert isinstance(entry, ModelErrors)
    assert entry.errors.translation.count == result.windows
    assert entry.errors.translation.median > 0.0
    assert math.isfinite(entry.ate.rmse)
    assert set(entry.to_dict()) == {
        "translation_m_per_m",
        "rotation_deg_per_m",
        "ate_dead_reckoning",
    }


def test_is_frozen(result: EvaluationResult) -> None:
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.windows = 0  # type: ignore[misc]  # the assignment under test


def test_writes_nothing_without_out_or_run(
    sim_output: SimOutput, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    cfg = Config(time=TimeConfig(pose_delay=0.05))

    result = evaluate(None, sim_output.log_csv, config=cfg, horizon=1.0)

    assert result.time_calibration.pose_delay == 0.05
    assert result.to_dict()["time_calibration"] == {"pose_delay_s": 0.05, "estimated": False}
    assert list(tmp_path.iterdir()) == []
