"""What ``terrain-odom evaluate`` runs: model-odometry errors of a run and of parameter files."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from terrain_odom.app.cluster import dask_cluster, run_jobs
from terrain_odom.app.evaluation_results import (
    BatchEvaluation,
    EvaluationResult,
    ModelErrors,
    PooledErrors,
)
from terrain_odom.app.inputs import (
    GIVEN,
    ConfigEdits,
    choose_config,
    read_calibrated_log,
    run_config,
)
from terrain_odom.app.locate import check_out, create_folder, output_file, writing_into
from terrain_odom.app.plots import EVALUATION_PLOTS, PLOTS_DIR, write_evaluation_plots
from terrain_odom.app.run_folder import TRAJECTORY_CSV, check_complete
from terrain_odom.config import Config, RobotConfig, load_config
from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.estimation.time_offset import TimeCalibration
from terrain_odom.evaluation import (
    DEFAULT_OUTAGES,
    AteResult,
    ModelAt,
    OutageErrors,
    PredictionSummary,
    RowsTwist,
    SE2Alignment,
    TwistFn,
    WindowErrors,
    Windows,
    absolute_trajectory_error,
    anchored_window_errors,
    antenna_of,
    dead_reckon,
    icr_twist_from_rows,
    is_sparse,
    log_anchor,
    model_twist,
    outage_spacing,
    outage_table,
    prediction_errors,
    prediction_windows,
    slip_twist_from_rows,
    spatial_windows,
    summarize,
)
from terrain_odom.fitting.params import check_geometry
from terrain_odom.io import read_trajectory_csv
from terrain_odom.io.atomic import write_text_atomic
from terrain_odom.io.params import read_params
from terrain_odom.io.paths import check_outputs
from terrain_odom.io.report import write_json
from terrain_odom.kinematics import get_model, twist_icr
from terrain_odom.kinematics.slip import SlipModel, param_names
from terrain_odom.records import WheelLog

__all__ = [
    "EVALUATION_JSON",
    "EVALUATION_MD",
    "JSON_SUFFIXES",
    "evaluate",
    "evaluate_logs",
]

EVALUATION_JSON = "evaluation.json"
"""The file :func:`evaluate` writes into its ``out_dir`` (or ``run_dir``)."""
EVALUATION_MD = "evaluation.md"
"""The table :func:`evaluate_logs` writes beside its ``evaluation.json``."""
BATCH_FILES = (EVALUATION_JSON, EVALUATION_MD)
"""The files :func:`evaluate_logs` writes into its ``out_dir``."""
JSON_SUFFIXES = (".json",)
"""Suffixes by which ``out_dir`` names the file itself (the old form)."""


def _read_run(run_dir: Path, log: WheelLog) -> dict[str, np.ndarray]:
    path = run_dir / TRAJECTORY_CSV
    if not path.is_file():
        raise InputFileError(f"{path}: no trajectory.csv in the run directory")
    traj = read_trajectory_csv(path)
    missing = [c for c in ("t", "y_l", "y_r", "x_icr") if c not in traj]
    if missing:
        raise InputFileError(f"{path}: missing column(s) {missing}")
    if len(traj["t"]) != len(log) or not np.allclose(traj["t"], log.t, rtol=0, atol=1e-6):
        raise InputFileError(
            f"{path}: its {len(traj['t'])} rows do not match the {len(log)} rows of "
            f"{log.source} (was the run made from this log?)"
        )
    return traj


_NO_ATE = AteResult(math.nan, SE2Alignment(math.nan, np.full(2, math.nan)), 0)
"""The ATE of a log without full poses: none (a dead-reckoned track needs a start heading)."""


@dataclass(frozen=True)
class _Scoring:
    """The windows of a log and how a model is scored on them.

    ``anchor``: what the windows run between (:data:`WINDOW_KINDS`);
    ``antenna``: where the measured positions are on the robot, m.
    """

    windows: Windows
    anchor: str
    antenna: tuple[float, float]

    def errors(self, log: WheelLog, twist_fn: TwistFn) -> WindowErrors:
        return anchored_window_errors(
            log, self.windows, twist_fn, anchor=self.anchor, antenna=self.antenna
        )


def _model_errors(
    log: WheelLog, scoring: _Scoring, twist_fn: TwistFn, rows: RowsTwist
) -> ModelErrors:
    """Window errors of ``twist_fn`` and the ATE of the per-row twist ``rows`` dead-reckoned."""
    errors = scoring.errors(log, twist_fn)
    if scoring.anchor != "pose":
        return ModelErrors(summarize(errors), _NO_ATE, errors)
    reckoned = dead_reckon(log, *rows)
    return ModelErrors(
        summarize(errors),
        absolute_trajectory_error(reckoned[:, :2], log.pose[:, :2]),
        errors,
    )


def _evaluation_windows(log: WheelLog, h_e: float, config: Config) -> _Scoring:
    """Windows between full poses, else between position fixes, else between heading rows."""
    antenna = antenna_of(config)
    anchor = log_anchor(log)
    if not log.has_yaw.any() and anchor == "heading":
        raise InputFileError(
            f"{log.source}: no pose measurements (x, y or yaw); nothing to evaluate"
        )
    windows = spatial_windows(log, h_e, anchor=anchor)
    if len(windows) == 0:
        between = {
            "pose": "with pose measurements at both ends",
            "position": "between position fixes (length by the wheels)",
            "heading": "between heading rows (length by the wheels)",
        }
        raise InputFileError(
            f"{log.source}: no {h_e} m window {between[anchor]}; nothing to evaluate"
        )
    return _Scoring(windows, anchor, antenna)


def _run_models(
    traj: dict[str, np.ndarray], log: WheelLog, scoring: _Scoring, ahead: Windows, config: Config
) -> tuple[str, ModelErrors, PredictionSummary, ModelAt]:
    """Errors of the online estimate of a run (ICR EKF, or slip EKF with ``l1`` columns).

    Also returns the run's model at window starts (for outage windows).
    """
    windows = scoring.windows
    if "l1" in traj:  # a slip-ekf run: the slip model with the parameters of each row
        slip_model = SlipModel.from_config(config.slip_ekf, config.robot.track_width)
        rows_l = np.stack([traj[n] for n in param_names("alpha" in traj)], axis=1)

        def slip_at(w: Windows) -> TwistFn:
            return slip_twist_from_rows(w, rows_l, slip_model)

        errors = _model_errors(
            log, scoring, slip_at(windows), slip_model.twist(log.v_l, log.v_r, rows_l)
        )
        return "slip-ekf (online)", errors, prediction_errors(log, ahead, slip_at(ahead)), slip_at
    icr = (traj["y_l"], traj["y_r"], traj["x_icr"], traj.get("alpha", np.ones(len(log))))

    def icr_at(w: Windows) -> TwistFn:
        return icr_twist_from_rows(w, *icr)

    errors = _model_errors(log, scoring, icr_at(windows), twist_icr(log.v_l, log.v_r, *icr))
    return "ekf (online)", errors, prediction_errors(log, ahead, icr_at(ahead)), icr_at


def _params_model(
    path: str | Path, log: WheelLog, scoring: _Scoring, robot: RobotConfig
) -> tuple[str, ModelErrors, ModelAt]:
    """Errors of the constant model of a parameter file (per-terrain sets row by row)."""
    mp = read_params(path)
    check_geometry(mp, robot.wheel_radius, robot.track_width, path)
    track_width = robot.track_width
    model = get_model(mp.model)
    values = mp.rows(log)  # (N, k): each row's terrain set (per-terrain files)
    b = mp.track_width or track_width
    v_x, v_y, omega = model.twist(log.v_l[:, None], log.v_r[:, None], values, b)

    def params_at(w: Windows) -> TwistFn:
        return model_twist(model, values[w.start], b)

    errors = _model_errors(
        log, scoring, params_at(scoring.windows), (v_x[:, 0], v_y[:, 0], omega[:, 0])
    )
    return f"{mp.model} ({Path(path).name})", errors, params_at


def _output_path(out_dir: str | Path | None, run_dir: str | Path | None) -> Path | None:
    if out_dir is not None:
        return output_file(out_dir, EVALUATION_JSON, JSON_SUFFIXES)
    return Path(run_dir) / EVALUATION_JSON if run_dir else None


def _evaluation_config(
    run_dir: str | Path | None,
    config: Config | None,
    config_path: str | Path | None,
    edits: ConfigEdits | None,
    imported: str | Path | None,
) -> Config:
    """Return the configuration to evaluate with: the run's own unless one is given.

    :func:`~terrain_odom.app.inputs.choose_config`. A given configuration
    file (``config_path``: one the user chose) must agree with the run's on
    the robot geometry.

    Raises
    ------
    ConfigError
        The given configuration's wheel radius or track width differs from the run's.
    """
    chosen = choose_config(config, config_path, edits=edits, imported=imported, run_dir=run_dir)
    recorded = None if run_dir is None else run_config(run_dir)
    if recorded is not None and chosen.file.how == GIVEN and chosen.path is not None:
        used = load_config(recorded).robot
        for name in ("wheel_radius", "track_width"):
            mine, theirs = getattr(chosen.config.robot, name), getattr(used, name)
            if mine != theirs:
                raise ConfigError(
                    f"{config_path}: robot.{name} {mine:g} m, but the run was made with "
                    f"{theirs:g} m ({recorded}); leave out --config to use the run's"
                )
    return chosen.config


def evaluate(
    run_dir: str | Path | None,
    wheels: str | Path,
    *,
    config: Config | None = None,
    config_path: str | Path | None = None,
    edits: ConfigEdits | None = None,
    imported_config: str | Path | None = None,
    params: Sequence[str | Path] | None = None,
    horizon: float | None = None,
    out_dir: str | Path | None = None,
    outage: Sequence[float] | None = None,
) -> EvaluationResult:
    """Model-odometry errors of the nominal model, an EKF run and parameter files.

    For every full pose measurement of the log, each model is integrated from
    that measured pose over the next ``horizon`` metres of measured travel and
    compared with the measured pose there (Baril et al. 2020); the EKF uses at
    each window start only the estimate it had then. Also reported: the ATE
    (after SE(2) alignment) of each model dead-reckoned over every segment
    from the segment's first measured pose. A log of positions and headings
    on different rows (a GPS and an IMU) has windows between position fixes
    (or heading rows) instead (:mod:`~terrain_odom.evaluation.sparse`,
    :data:`WINDOW_KINDS`) and no ATE. With a run, outage windows
    (:mod:`~terrain_odom.evaluation.outage`): each model dead-reckoned from
    the run's state through ``outage`` seconds without poses.

    Parameters
    ----------
    run_dir : str or Path, optional
        Output directory of :func:`run` on the same log; refused unless the
        run completed (:func:`~terrain_odom.app.run_folder.check_complete`).
    wheels : str or Path
        The wheel log with pose measurements.
    config, config_path : optional
        Configuration (robot geometry, default horizon, ``time.pose_delay``:
        give the one the run was made with), or its file; without either, the
        run's ``config.yaml``, else ``imported_config``, else the built-in
        defaults (:func:`~terrain_odom.app.inputs.choose_config`).
    edits : ConfigEdits, optional
        The command line's changes to a configuration file's values.
    imported_config : str or Path, optional
        The configuration written by the import of a bag (``--wheels BAG``).
    params : sequence of str or Path, optional
        Parameter files of constant models (see :mod:`terrain_odom.io.params`).
    horizon : float, optional
        Evaluation horizon ``h_e``, m; ``config.evaluation.horizon`` if omitted.
    out_dir : str or Path, optional
        Folder (created) to write ``evaluation.json`` into; ``run_dir`` by
        default. A name ending in ``.json`` is the file itself (the old form).
        ``InputFileError`` before anything is read if it is an input.
    outage : sequence of float, optional
        Outage durations, s (``ConfigError`` without a run, or for one no
        window of the log lasts); by default 30 s and 60 s when the run's
        log has sparse (GPS-like) poses (:func:`~terrain_odom.evaluation.is_sparse`),
        none otherwise. Empty: none.

    Returns
    -------
    EvaluationResult
        Per model: translational (m/m) and angular (deg/m) error statistics
        and dead-reckoning ATE (m); 2-s prediction errors; outage errors.
    """
    if run_dir is not None:
        check_complete(run_dir)
    target = _output_path(out_dir, run_dir)
    if out_dir is not None:
        check_out(out_dir, JSON_SUFFIXES)
    if target is not None:
        trajectory = None if run_dir is None else Path(run_dir) / TRAJECTORY_CSV
        plots = [target.parent / PLOTS_DIR / name for name in EVALUATION_PLOTS]
        check_outputs([wheels, config_path, trajectory, *(params or [])], [target, *plots])
    config = _evaluation_config(run_dir, config, config_path, edits, imported_config)
    log, timing = read_calibrated_log(wheels, config)
    result = _evaluation(
        log, timing, wheels, config, run_dir=run_dir, params=params, horizon=horizon, outage=outage
    )
    result = dataclasses.replace(result, output=target)
    if target is None:
        return result
    if out_dir is not None:
        create_folder(out_dir, JSON_SUFFIXES)
    names = [EVALUATION_JSON, *(f"{PLOTS_DIR}/{name}" for name in EVALUATION_PLOTS)]
    with writing_into(out_dir, target, "evaluate", names, JSON_SUFFIXES):
        write_json(target, result.to_dict())
        errors = {name: m.windows for name, m in result.models.items() if m.windows is not None}
        plots = write_evaluation_plots(
            target.parent / PLOTS_DIR, log, errors, result.horizon, result.outages
        )
    return dataclasses.replace(result, plots=tuple(plots))


def _evaluate_log(
    wheels: str | Path,
    *,
    config: Config,
    params: Sequence[str | Path] | None = None,
    horizon: float | None = None,
) -> EvaluationResult:
    """Read one log and evaluate it as :func:`evaluate` does, writing nothing (a batch task)."""
    log, timing = read_calibrated_log(wheels, config)
    return _evaluation(log, timing, wheels, config, params=params, horizon=horizon)


def _evaluation(
    log: WheelLog,
    timing: TimeCalibration,
    wheels: str | Path,
    config: Config,
    *,
    run_dir: str | Path | None = None,
    params: Sequence[str | Path] | None = None,
    horizon: float | None = None,
    outage: Sequence[float] | None = None,
) -> EvaluationResult:
    """Errors of the nominal model, the run and the parameter files on ``log`` (read from ``wheels``)."""
    h_e = config.evaluation.horizon if horizon is None else float(horizon)
    scoring = _evaluation_windows(log, h_e, config)
    b = config.robot.track_width
    idd = get_model("idd")
    nominal = f"idd (B={b:g} m)"
    idd_twist = model_twist(idd, [], b)
    idd_rows = idd.twist(log.v_l, log.v_r, [], b)
    models = {nominal: _model_errors(log, scoring, idd_twist, idd_rows)}
    at: dict[str, ModelAt | RowsTwist] = {nominal: idd_rows}
    ahead = prediction_windows(log)
    prediction = {nominal: prediction_errors(log, ahead, idd_twist)}
    traj = None if run_dir is None else _read_run(Path(run_dir), log)
    if traj is not None:
        name, models[name], prediction[name], at[name] = _run_models(
            traj, log, scoring, ahead, config
        )
    for path in params or []:
        name, models[name], at[name] = _params_model(path, log, scoring, config.robot)
    return EvaluationResult(
        log=Path(wheels).resolve(),
        run=None if run_dir is None else Path(run_dir).resolve(),
        time_calibration=timing,
        horizon=h_e,
        windows=len(scoring.windows),
        models=models,
        prediction_windows=len(ahead),
        prediction=prediction,
        anchor=scoring.anchor,
        outages=_outages(log, traj, at, scoring.antenna, outage),
        outage_every=outage_spacing(log),
    )


def _outages(
    log: WheelLog,
    traj: dict[str, np.ndarray] | None,
    models: dict[str, ModelAt | RowsTwist],
    antenna: tuple[float, float],
    durations: Sequence[float] | None,
) -> dict[float, dict[str, OutageErrors]]:
    """Outage windows of every model from the run's state: asked for, or by default on sparse poses.

    Raises
    ------
    ConfigError
        Durations asked for without a run, or one without a single window in the log.
    """
    if traj is None:
        if durations:
            raise ConfigError("--outage dead-reckons from a run's state: give --run")
        return {}
    if durations is None:
        if not is_sparse(log):
            return {}
        durations = DEFAULT_OUTAGES
    table = outage_table(log, durations, lambda rows: traj["yaw"][rows], models, antenna=antenna)
    missing = [d for d in durations if float(d) not in table]
    if missing and durations is not DEFAULT_OUTAGES:
        rows = np.flatnonzero(log.has_position)
        span = float(log.t[rows[-1]] - log.t[rows[0]]) if rows.size else 0.0
        raise ConfigError(
            f"--outage {missing[0]:g}s: no outage window of {log.source} lasts that long between "
            f"position fixes of one segment (they span {span:.1f} s); give a shorter duration"
        )
    return table


def evaluate_logs(
    wheels: Sequence[str | Path],
    *,
    config: Config | None = None,
    config_path: str | Path | None = None,
    edits: ConfigEdits | None = None,
    imported_config: str | Path | None = None,
    params: Sequence[str | Path] | None = None,
    horizon: float | None = None,
    out_dir: str | Path | None = None,
    dask: str | None = None,
) -> BatchEvaluation:
    """Evaluate the nominal model and parameter files on many logs: per log and pooled.

    Each log is evaluated as by :func:`evaluate` (without a run), in a joblib
    task; the window errors of every log are then pooled per model.

    Parameters
    ----------
    wheels : sequence of str or Path
        Wheel logs with pose measurements (a log with no window is an error).
    config, config_path, edits, imported_config, params, horizon
        As for :func:`evaluate`, the same for every log.
    out_dir : str or Path, optional
        Folder (created) to write ``evaluation.json`` and ``evaluation.md``
        into; ``InputFileError`` before anything is read if one is an input.
    dask : str, optional
        Evaluate the logs on this Dask cluster (``tcp://host:port`` or
        ``local:N``, :func:`~terrain_odom.app.cluster.dask_cluster`): the
        workers read the logs and parameter files by their paths. Without it,
        one after the other in this process. The same result either way.

    Returns
    -------
    BatchEvaluation
    """
    if not wheels:
        raise InputFileError("no wheel log given")
    targets = [] if out_dir is None else [Path(out_dir) / name for name in BATCH_FILES]
    check_outputs([*wheels, config_path, *(params or [])], targets)
    chosen = choose_config(config, config_path, edits=edits, imported=imported_config)
    with dask_cluster(dask) as cluster:
        results = run_jobs(
            _evaluate_log,
            [str(path) for path in wheels],
            cluster,
            config=chosen.config,
            params=[str(path) for path in params or []],
            horizon=horizon,
        )
    pooled = {
        name: PooledErrors.of([r.models[name] for r in results]) for name in results[0].models
    }
    batch = BatchEvaluation(tuple(results), pooled)
    if out_dir is None:
        return batch
    Path(out_dir).mkdir(parents=True, exist_ok=True)
    write_json(targets[0], batch.to_dict())
    write_text_atomic(targets[1], batch.markdown())
    return dataclasses.replace(batch, outputs=tuple(targets))
