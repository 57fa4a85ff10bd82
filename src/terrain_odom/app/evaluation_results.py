"""What ``terrain-odom evaluate`` computes, as typed records written as ``evaluation.json``.

:class:`EvaluationResult` is one log's evaluation (:func:`~terrain_odom.app.evaluate.evaluate`),
:class:`BatchEvaluation` several logs' with their pooled errors
(:func:`~terrain_odom.app.evaluate.evaluate_logs`, also ``evaluation.md``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from terrain_odom.estimation.time_offset import TimeCalibration
from terrain_odom.evaluation import (
    OUTAGE_EVERY,
    AteResult,
    ErrorSummary,
    OutageErrors,
    PredictionSummary,
    WindowErrors,
    summarize,
)
from terrain_odom.io.report import path_or_none, report_header
from terrain_odom.reporting.outage import outage_section
from terrain_odom.reporting.tables import evaluation_markdown

__all__ = ["WINDOW_KINDS", "ModelErrors", "EvaluationResult", "PooledErrors", "BatchEvaluation"]

WINDOW_KINDS = {
    "pose": "between full poses",
    "position": "between position fixes, length from the wheels (start heading fitted to "
    "the fixes; heading change from the heading rows where present)",
    "heading": "between heading rows (length from the wheels; heading change only)",
}
"""What each window anchor means, as the printout and reports say it."""


@dataclass(frozen=True)
class ModelErrors:
    """Model-odometry errors of one model on the log.

    Attributes
    ----------
    errors : ErrorSummary
        Translational (m/m) and angular (deg/m) error per metre over the windows.
    ate : AteResult
        ATE of the model dead-reckoned over every segment, m.
    windows : WindowErrors or None
        The errors window by window (what the plots draw).
    """

    errors: ErrorSummary
    ate: AteResult
    windows: WindowErrors | None = None

    def to_dict(self) -> dict[str, Any]:
        """Return the model's entry of ``evaluation.json``."""
        return {**self.errors.to_dict(), "ate_dead_reckoning": self.ate.to_dict()}


@dataclass(frozen=True)
class EvaluationResult:
    """What :func:`evaluate` computed (and wrote as ``evaluation.json``).

    Attributes
    ----------
    log : Path
        The wheel log (absolute).
    run : Path or None
        The run directory (absolute), when a run was evaluated.
    time_calibration : TimeCalibration
        The pose delay applied to the log.
    horizon : float
        Evaluation horizon ``h_e``, m.
    windows : int
        Number of ``h_e`` windows.
    models : dict of str to ModelErrors
        Per model, in the order evaluated: the nominal ``idd``, the run, the
        parameter files.
    prediction_windows : int
        Number of 2-s prediction windows.
    prediction : dict of str to PredictionSummary
        2-s prediction errors of the nominal model and of the run.
    output : Path or None
        The JSON file written (``None``: nothing written).
    plots : tuple of Path
        PNG plots written beside it, in ``plots/`` (:func:`write_evaluation_plots`).
    anchor : str
        What the windows run between: ``"pose"``, ``"position"`` or
        ``"heading"`` (:data:`WINDOW_KINDS`; a log of positions and headings
        on different rows has no full pose).
    outages : dict of float to dict of str to OutageErrors
        Per outage duration (s), per model: dead reckoning from the run's
        state through the outage windows (:mod:`~terrain_odom.evaluation.outage`).
    outage_every : float
        Time between their starts, s (:func:`~terrain_odom.evaluation.outage_spacing`).
    """

    log: Path
    run: Path | None
    time_calibration: TimeCalibration
    horizon: float
    windows: int
    models: dict[str, ModelErrors]
    prediction_windows: int
    prediction: dict[str, PredictionSummary]
    output: Path | None = None
    plots: tuple[Path, ...] = ()
    anchor: str = "pose"
    outages: dict[float, dict[str, OutageErrors]] = dataclasses.field(default_factory=dict)
    outage_every: float = OUTAGE_EVERY

    def to_dict(self) -> dict[str, Any]:
        """Return the content of ``evaluation.json``."""
        return {
            **report_header("evaluate"),
            "log": str(self.log),
            "run": path_or_none(self.run),
            "time_calibration": self.time_calibration.to_dict(),
            "horizon_m": self.horizon,
            "windows": self.windows,
            "windows_between": self.anchor,
            "windows_note": WINDOW_KINDS[self.anchor],
            "models": {name: entry.to_dict() for name, entry in self.models.items()},
            "prediction_2s": {
                "windows": self.prediction_windows,
                "models": {name: p.to_dict() for name, p in self.prediction.items()},
            },
            **(
                {"outages": outage_section(self.outages, self.outage_every)} if self.outages else {}
            ),
        }


@dataclass(frozen=True)
class PooledErrors:
    """Errors of one model pooled over the logs of a batch.

    Attributes
    ----------
    errors : ErrorSummary
        Statistics of every log's windows together.
    ate_rmse : float
        Dead-reckoning ATE over every compared row of every log, m (each log
        aligned on its own): ``sqrt(sum(count_i rmse_i^2) / sum(count_i))``.
    ate_count : int
        Rows compared.
    """

    errors: ErrorSummary
    ate_rmse: float
    ate_count: int

    @classmethod
    def of(cls, entries: Sequence[ModelErrors]) -> PooledErrors:
        """Pool one model's entries of several logs."""
        count = sum(e.ate.count for e in entries)
        square = sum(e.ate.count * e.ate.rmse**2 for e in entries)
        return cls(
            summarize([e.windows for e in entries if e.windows is not None]),
            math.sqrt(square / count) if count else math.nan,
            count,
        )

    def to_dict(self) -> dict[str, Any]:
        """Return the model's ``pooled`` entry of ``evaluation.json``."""
        rmse = None if math.isnan(self.ate_rmse) else self.ate_rmse
        return {
            **self.errors.to_dict(),
            "ate_dead_reckoning": {"rmse_m": rmse, "count": self.ate_count},
        }


@dataclass(frozen=True)
class BatchEvaluation:
    """What :func:`evaluate_logs` computed (and wrote as ``evaluation.json``, ``evaluation.md``).

    Attributes
    ----------
    logs : tuple of EvaluationResult
        Each log's evaluation, in the order given.
    pooled : dict of str to PooledErrors
        Per model, the errors of all the logs together.
    outputs : tuple of Path
        Files written (empty without ``out_dir``).
    """

    logs: tuple[EvaluationResult, ...]
    pooled: dict[str, PooledErrors]
    outputs: tuple[Path, ...] = ()

    @property
    def horizon(self) -> float:
        """Evaluation horizon ``h_e``, m."""
        return self.logs[0].horizon

    def to_dict(self) -> dict[str, Any]:
        """Return the content of ``evaluation.json``: per log as :func:`evaluate`'s, and pooled."""
        header = report_header("evaluate")
        return {
            **header,
            "horizon_m": self.horizon,
            "logs": [{k: v for k, v in r.to_dict().items() if k not in header} for r in self.logs],
            "pooled": {
                "logs": len(self.logs),
                "windows": sum(r.windows for r in self.logs),
                "models": {name: p.to_dict() for name, p in self.pooled.items()},
            },
        }

    def markdown(self) -> str:
        """Return the table of ``evaluation.md``: one row per log and model, then the pooled rows."""
        rows = [
            (r.log.name, name, r.windows, entry.errors, entry.ate.rmse)
            for r in self.logs
            for name, entry in r.models.items()
        ]
        rows += [
            (f"all {len(self.logs)} logs", name, p.errors.translation.count, p.errors, p.ate_rmse)
            for name, p in self.pooled.items()
        ]
        notes = [
            f"{r.log.name}: windows {WINDOW_KINDS[r.anchor]}"
            for r in self.logs
            if r.anchor != "pose"
        ]
        return evaluation_markdown(self.horizon, rows, notes)
