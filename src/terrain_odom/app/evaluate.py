"""What ``terrain-odom evaluate`` runs: model-odometry errors of a run and of parameter files."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from terrain_odom.app.run import read_calibrated_log
from terrain_odom.config import Config, load_config
from terrain_odom.errors import InputFileError
from terrain_odom.evaluation import (
    absolute_trajectory_error,
    dead_reckon,
    icr_twist_from_rows,
    model_twist,
    spatial_windows,
    summarize,
    window_errors,
)
from terrain_odom.evaluation.prediction import (
    prediction_errors,
    prediction_windows,
    slip_twist_from_rows,
)
from terrain_odom.io import read_trajectory_csv
from terrain_odom.io.params import ModelParams, read_params
from terrain_odom.io.report import path_or_none, report_header, write_json
from terrain_odom.kinematics import get_model, twist_icr
from terrain_odom.kinematics.slip import SlipModel, param_names
from terrain_odom.records import WheelLog

__all__ = ["evaluate"]


def _read_run(run_dir: Path, log: WheelLog) -> dict[str, np.ndarray]:
    path = run_dir / "trajectory.csv"
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


def _model_entry(log: WheelLog, windows: Any, twist_fn: Any, rows_twist: tuple) -> dict:
    errors = window_errors(log, windows, twist_fn)
    reckoned = dead_reckon(log, *rows_twist)
    ate = absolute_trajectory_error(reckoned[:, :2], log.pose[:, :2])
    return {**summarize(errors).to_dict(), "ate_dead_reckoning": ate.to_dict()}


def evaluate(
    run_dir: str | Path | None,
    wheels: str | Path,
    *,
    config: Config | None = None,
    config_path: str | Path | None = None,
    params: list[str | Path] | None = None,
    horizon: float | None = None,
    out: str | Path | None = None,
) -> dict[str, Any]:
    """Model-odometry errors of the nominal model, an EKF run and parameter files.

    For every full pose measurement of the log, each model is integrated from
    that measured pose over the next ``horizon`` metres of measured travel and
    compared with the measured pose there (Baril et al. 2020); the EKF uses at
    each window start only the estimate it had then. Also reported: the ATE
    (after SE(2) alignment) of each model dead-reckoned over every segment
    from the segment's first measured pose.

    Parameters
    ----------
    run_dir : str or Path, optional
        Output directory of :func:`run` on the same log.
    wheels : str or Path
        The wheel log with pose measurements.
    config, config_path : optional
        Configuration (robot geometry, default horizon, ``time.pose_delay``:
        give the one the run was made with).
    params : list of str or Path, optional
        Parameter files of constant models (see :mod:`terrain_odom.io.params`).
    horizon : float, optional
        Evaluation horizon ``h_e``, m; ``config.evaluation.horizon`` if omitted.
    out : str or Path, optional
        Where to write the JSON result; ``run_dir/evaluation.json`` by default.

    Returns
    -------
    dict
        Per model: translational (m/m) and angular (deg/m) error statistics
        and dead-reckoning ATE (m).
    """
    cfg = config if config is not None else load_config(config_path)
    log, timing = read_calibrated_log(wheels, cfg)
    h_e = cfg.evaluation.horizon if horizon is None else float(horizon)
    windows = spatial_windows(log, h_e)
    if len(windows) == 0:
        raise InputFileError(
            f"{log.source}: no {h_e} m window with pose measurements at both ends; nothing to evaluate"
        )
    b_nominal = cfg.robot.track_width
    idd = get_model("idd")
    models: dict[str, Any] = {
        f"idd (B={b_nominal:g} m)": _model_entry(
            log,
            windows,
            model_twist(idd, [], b_nominal),
            idd.twist(log.v_l, log.v_r, [], b_nominal),
        )
    }
    ahead = prediction_windows(log)
    idd_errors = prediction_errors(log, ahead, model_twist(idd, [], b_nominal))
    prediction = {next(iter(models)): idd_errors.to_dict()}
    if run_dir is not None:
        traj = _read_run(Path(run_dir), log)
        alpha = traj.get("alpha", np.ones(len(log)))
        icr = (traj["y_l"], traj["y_r"], traj["x_icr"], alpha)
        if "l1" in traj:  # a slip-ekf run: the slip model with the parameters of each row
            slip_model = SlipModel.from_config(cfg.slip_ekf, b_nominal)
            rows_l = np.stack([traj[n] for n in param_names("alpha" in traj)], axis=1)
            models["slip-ekf (online)"] = _model_entry(
                log,
                windows,
                slip_twist_from_rows(windows, rows_l, slip_model),
                slip_model.twist(log.v_l, log.v_r, rows_l),
            )
            run_twist = slip_twist_from_rows(ahead, rows_l, slip_model)
        else:
            models["ekf (online)"] = _model_entry(
                log, windows, icr_twist_from_rows(windows, *icr), twist_icr(log.v_l, log.v_r, *icr)
            )
            run_twist = icr_twist_from_rows(ahead, *icr)
        prediction[list(models)[-1]] = prediction_errors(log, ahead, run_twist).to_dict()
    for path in params or []:
        mp: ModelParams = read_params(path)
        model = get_model(mp.model)
        values = mp.rows(log)  # (N, k): each row's terrain set (per-terrain files)
        b = mp.track_width or b_nominal
        rows_twist = model.twist(log.v_l[:, None], log.v_r[:, None], values, b)
        models[f"{mp.model} ({Path(path).name})"] = _model_entry(
            log,
            windows,
            model_twist(model, values[windows.start], b),
            tuple(c[:, 0] for c in rows_twist),
        )
    result = {
        **report_header("evaluate"),
        "log": str(Path(wheels).resolve()),
        "run": path_or_none(run_dir),
        "time_calibration": timing.to_dict(),
        "horizon_m": h_e,
        "windows": len(windows),
        "models": models,
        "prediction_2s": {"windows": len(ahead), "models": prediction},
    }
    target = (
        Path(out) if out is not None else (Path(run_dir) / "evaluation.json" if run_dir else None)
    )
    if target is not None:
        write_json(target, result)
    return result
