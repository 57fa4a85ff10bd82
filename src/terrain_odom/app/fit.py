"""Offline model identification workflows: what ``terrain-odom fit`` and ``compare`` run.

:func:`fit` fits one constant kinematic model (one set, or one per terrain)
on training logs and writes a parameter file; :func:`compare` fits every
model and writes Baril-style tables (Markdown, JSON) and a box plot. The
computation lives in :mod:`terrain_odom.fitting.identify` and
:mod:`terrain_odom.evaluation`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from terrain_odom import __version__
from terrain_odom.app.cluster import dask_cluster, run_jobs
from terrain_odom.app.locate import check_out, create_folder, output_file, writing_into
from terrain_odom.app.run import calibrate_log
from terrain_odom.config import Config, load_config
from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.estimation.time_offset import TimeCalibration
from terrain_odom.evaluation import (
    ErrorSummary,
    WindowErrors,
    Windows,
    anchored_window_errors,
    antenna_of,
    log_anchor,
    model_twist,
    spatial_windows,
    summarize,
)
from terrain_odom.fitting import (
    DEFAULT_TRAINING_HORIZON,
    FitOptions,
    FitResult,
    Horizon,
    fit_model,
    parse_horizon,
    segment_set,
    training_windows,
)
from terrain_odom.fitting.params import ANY_TERRAIN, ModelParams, ParamSet, derived_quantities
from terrain_odom.io import read_wheel_log
from terrain_odom.io.atomic import write_atomic, write_text_atomic
from terrain_odom.io.folder import writing_if
from terrain_odom.io.params import write_params
from terrain_odom.io.paths import check_outputs
from terrain_odom.io.report import write_json
from terrain_odom.kinematics import MODELS, get_model
from terrain_odom.records import WheelLog
from terrain_odom.reporting.figure import save_png
from terrain_odom.reporting.markdown import table
from terrain_odom.reporting.model_errors import error_boxes_figure, error_values

__all__ = [
    "LogSource",
    "FitEvaluation",
    "FitReport",
    "ModelComparison",
    "CompareReport",
    "fit",
    "evaluate_params",
    "compare",
    "params_file_name",
    "YAML_SUFFIXES",
]

LogSource = str | Path | WheelLog
"""A wheel-log CSV path, or an already loaded :class:`WheelLog`."""

COMPARE_FILES = ("compare.md", "compare.json", "compare.png")
"""Files :func:`compare` writes into its ``out_dir`` (besides ``params_MODEL.yaml``)."""
YAML_SUFFIXES = (".yaml", ".yml")
"""Suffixes by which :func:`fit`'s ``out`` names the parameter file itself (the old form)."""


def params_file_name(model: str) -> str:
    """Return the name of a model's parameter file in an output folder: ``params_<model>.yaml``."""
    return f"params_{model}.yaml"


ALL = "all"  # group name of evaluation windows when fits are not per terrain


@dataclass(frozen=True)
class FitEvaluation:
    """Held-out errors of a fitted model and of the ideal differential drive.

    Attributes
    ----------
    horizon : float
        Evaluation horizon ``h_e``, m.
    logs : tuple of str
        The evaluation logs (their ``source``).
    groups : dict of str to dict of str to ErrorSummary
        Per group (terrain or ``"all"``), per model name: pooled error statistics.
    """

    horizon: float
    logs: tuple[str, ...]
    groups: dict[str, dict[str, ErrorSummary]]

    def to_dict(self) -> dict[str, Any]:
        """Return the ``evaluation`` entry of the parameter file."""
        return {
            "horizon_m": self.horizon,
            "logs": list(self.logs),
            "groups": {
                g: {name: s.to_dict() for name, s in models.items()}
                for g, models in self.groups.items()
            },
        }


@dataclass(frozen=True)
class FitReport:
    """Result of :func:`fit`.

    Attributes
    ----------
    params : ModelParams
        The fitted model (what was written to the parameter file).
    fits : dict of str to FitResult
        The optimiser's result per terrain (``"*"`` without per-terrain sets).
    skipped : tuple of str
        Terrains left out because no training segment lies on them.
    evaluation : FitEvaluation or None
        With evaluation logs: error statistics of the fitted model and of the
        ideal differential drive, per group (terrain or ``"all"``).
    time_calibration : dict of str to TimeCalibration
        Per log (its ``source``): the pose delay applied (see
        ``config.time.pose_delay``).
    output : Path or None
        The parameter file written (None without ``out``).
    """

    params: ModelParams
    fits: dict[str, FitResult]
    skipped: tuple[str, ...] = ()
    evaluation: FitEvaluation | None = None
    time_calibration: dict[str, TimeCalibration] = field(default_factory=dict)
    output: Path | None = None

    @property
    def seconds(self) -> dict[str, float]:
        """Fit wall time per terrain (``"*"`` without per-terrain sets), s."""
        return {k: f.seconds for k, f in self.fits.items()}


@dataclass(frozen=True)
class ModelComparison:
    """One model of :func:`compare`: its fitted sets and held-out errors.

    Attributes
    ----------
    params : ModelParams
        The fitted model (what was written to ``params_<model>.yaml``).
    skipped : tuple of str
        Terrains left out because no training segment lies on them.
    errors : dict of str to ErrorSummary
        Held-out error statistics per group (terrain or ``"all"``).
    """

    params: ModelParams
    skipped: tuple[str, ...]
    errors: dict[str, ErrorSummary]

    def to_dict(self) -> dict[str, Any]:
        """Return the model's entry of ``compare.json``."""
        mp = self.params
        return {
            "sets": {k: {"params": v.params, "fit": v.fit} for k, v in mp.sets.items()},
            "derived": {
                k: derived_quantities(mp.model, v.params, mp.track_width)
                for k, v in mp.sets.items()
            },
            "skipped_terrains": list(self.skipped),
            "errors": {g: e.to_dict() for g, e in self.errors.items()},
        }


@dataclass(frozen=True)
class CompareReport:
    """Result of :func:`compare` (written as ``compare.json``).

    Attributes
    ----------
    training_logs, evaluation_logs : tuple of str
        The logs (their ``source``).
    horizon_train : Horizon
        Training horizon ``h_t``.
    horizon_eval : float
        Evaluation horizon ``h_e``, m.
    track_width : float
        Nominal ``B``, m.
    time_calibration : dict of str to TimeCalibration
        Per log: the pose delay applied.
    models : dict of str to ModelComparison
        Per model, in the order compared.
    markdown : str
        The tables (``compare.md``).
    outputs : tuple of Path
        Files written (empty without ``out_dir``).
    """

    training_logs: tuple[str, ...]
    evaluation_logs: tuple[str, ...]
    horizon_train: Horizon
    horizon_eval: float
    track_width: float
    time_calibration: dict[str, TimeCalibration]
    models: dict[str, ModelComparison]
    markdown: str
    outputs: tuple[Path, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """Return the content of ``compare.json``."""
        return {
            "terrain_odom_version": __version__,
            "command": "compare",
            "training_logs": list(self.training_logs),
            "evaluation_logs": list(self.evaluation_logs),
            "horizon_train": str(self.horizon_train),
            "horizon_eval_m": self.horizon_eval,
            "track_width_m": self.track_width,
            "time_calibration": {k: t.to_dict() for k, t in self.time_calibration.items()},
            "models": {name: m.to_dict() for name, m in self.models.items()},
            "markdown": self.markdown,
        }


def _paths(
    logs: Sequence[LogSource], eval_logs: Sequence[LogSource], config_path: str | Path | None
) -> list[str | Path | None]:
    """Return the files read by :func:`fit` or :func:`compare` (logs given as paths, config)."""
    read = [src for src in (*logs, *eval_logs) if not isinstance(src, WheelLog)]
    return [*read, config_path]


def _recorded_delay(timing: dict[str, TimeCalibration]) -> float | dict[str, float]:
    """Return the pose delay the logs were read with, s: one value, or one per differing log."""
    delays = {source: t.pose_delay for source, t in timing.items()}
    values = set(delays.values())
    return values.pop() if len(values) == 1 else delays


def _load(
    sources: Sequence[LogSource], cfg: Config, role: str, timing: dict[str, TimeCalibration]
) -> list[WheelLog]:
    """Read the logs and apply ``cfg.time.pose_delay`` to each; record it in ``timing``."""
    logs = []
    for src in sources:
        log = (
            src
            if isinstance(src, WheelLog)
            else read_wheel_log(src, wheel_radius=cfg.robot.wheel_radius)
        )
        if not np.isfinite(log.pose).any():
            raise InputFileError(
                f"{log.source}: no pose measurements (x, y or yaw); a {role} log needs them"
            )
        log, calibration = calibrate_log(log, cfg)
        timing[log.source] = calibration
        logs.append(log)
    if not logs:
        raise InputFileError(f"no {role} log given")
    return logs


def _horizon(value: str | float | Horizon) -> Horizon:
    if isinstance(value, Horizon):
        return value
    try:
        return parse_horizon(value)
    except ValueError as exc:
        raise ConfigError(str(exc)) from None


def _terrains(logs: Sequence[WheelLog]) -> list[str]:
    columns = []
    for log in logs:
        if log.terrain is None:
            raise InputFileError(f"{log.source}: no terrain column; --by-terrain needs one")
        columns.append(log.terrain)
    return sorted({str(x) for column in columns for x in np.unique(column)})


def _fit_sets(
    model: str,
    logs: Sequence[WheelLog],
    horizon: Horizon,
    by_terrain: bool,
    options: FitOptions,
    track_width: float,
    antenna: tuple[float, float] = (0.0, 0.0),
) -> tuple[dict[str, ParamSet], dict[str, FitResult], tuple[str, ...]]:
    """Fit one set (``ANY_TERRAIN``) or one per terrain.

    Each log's segments run between its full poses, else between its
    position fixes, else between its heading rows (:func:`~terrain_odom.evaluation.log_anchor`).
    """
    groups = _terrains(logs) if by_terrain else [None]
    anchors = [log_anchor(log) for log in logs]
    sets: dict[str, ParamSet] = {}
    fits: dict[str, FitResult] = {}
    skipped = []
    for terrain in groups:
        windows = [
            training_windows(log, horizon, terrain, a) for log, a in zip(logs, anchors, strict=True)
        ]
        segments = segment_set(logs, windows, anchor=anchors, antenna=antenna)
        if segments.count == 0:
            skipped.append(str(terrain))
            continue
        result = fit_model(model, segments, options=options, track_width=track_width)
        key = ANY_TERRAIN if terrain is None else terrain
        sets[key] = ParamSet(
            result.as_dict(),
            {
                "loss": result.loss,
                "segments": result.segments,
                "length_m": result.length,
                "duration_s": result.duration,
                "seconds": result.seconds,
            },
            result.at_bounds,
        )
        fits[key] = result
    if not sets:
        where = "" if not by_terrain else " on any terrain"
        raise InputFileError(
            f"no training segment of {horizon}{where} in "
            f"{', '.join(log.source for log in logs)} (pose measurements never that far apart "
            f"within a segment; fixes or headings alone: as far as the wheels say); use a "
            "shorter --horizon"
        )
    return sets, fits, tuple(skipped)


def _group_errors(
    mp: ModelParams,
    logs: Sequence[WheelLog],
    h_e: float,
    track_width: float,
    antenna: tuple[float, float] = (0.0, 0.0),
) -> dict[str, list[WindowErrors]]:
    """Window errors of a model on evaluation logs, grouped by start-row terrain."""
    model = get_model(mp.model)
    groups: dict[str, list[WindowErrors]] = {}
    for log in logs:
        anchor = log_anchor(log)
        windows = spatial_windows(log, h_e, anchor=anchor)
        if len(windows) == 0:
            continue
        values = mp.rows(log)  # per-terrain sets need (and check) the terrain column
        labels = np.asarray(log.terrain) if mp.per_terrain else np.full(len(log), ALL)
        b = mp.track_width or track_width
        twist = model_twist(model, values[windows.start], b)
        errors = anchored_window_errors(log, windows, twist, anchor=anchor, antenna=antenna)
        start_labels = labels[windows.start]
        for label in np.unique(start_labels):
            keep = np.flatnonzero(start_labels == label)
            groups.setdefault(str(label), []).append(_subset(errors, keep))
    return groups


def _subset(errors: WindowErrors, keep: np.ndarray) -> WindowErrors:
    w = errors.windows
    return WindowErrors(
        windows=Windows(start=w.start[keep], end=w.end[keep], length=w.length[keep]),
        predicted=errors.predicted[keep],
        translation=errors.translation[keep],
        rotation=errors.rotation[keep],
    )


def evaluate_params(
    mp: ModelParams,
    logs: Sequence[WheelLog],
    h_e: float,
    track_width: float,
    antenna: tuple[float, float] = (0.0, 0.0),
) -> dict[str, ErrorSummary]:
    """Error statistics of a fitted model on evaluation logs, per terrain (or ``"all"``).

    Parameters
    ----------
    mp : ModelParams
        The model; per-terrain sets are applied to the windows starting on
        their terrain.
    logs : sequence of WheelLog
        Evaluation logs.
    h_e : float
        Evaluation horizon, m.
    track_width : float
        Nominal ``B``, m (when ``mp`` has none).
    antenna : tuple of 2 floats, optional
        Where the position sensor is, m (logs of GPS fixes, :func:`~terrain_odom.evaluation.antenna_of`).

    Returns
    -------
    dict of str to ErrorSummary
        Pooled over the logs, per group.
    """
    groups = _group_errors(mp, logs, h_e, track_width, antenna)
    return {k: summarize(v) for k, v in groups.items()}


def _idd(mp: ModelParams, track_width: float) -> ModelParams:
    """Return the ideal differential drive with the same grouping as ``mp``."""
    return ModelParams("idd", {k: ParamSet({}) for k in mp.sets}, track_width)


def fit(
    logs: Sequence[LogSource],
    model: str,
    *,
    out: str | Path | None = None,
    horizon: str | float | Horizon = DEFAULT_TRAINING_HORIZON,
    eval_logs: Sequence[LogSource] = (),
    by_terrain: bool = False,
    options: FitOptions | None = None,
    config: Config | None = None,
    config_path: str | Path | None = None,
) -> FitReport:
    """Fit a constant kinematic model on training logs and write a parameter file.

    Parameters
    ----------
    logs : sequence of str, Path or WheelLog
        Training logs with pose measurements; the loss sums over all of them
        (so it does not matter how a run is split into files at segment breaks).
    model : str
        A name from :data:`terrain_odom.kinematics.MODELS`.
    out : str or Path, optional
        Folder (created) to write the parameter file ``params_<model>.yaml``
        into (YAML, see :mod:`terrain_odom.io.params`); a name ending in
        ``.yaml`` or ``.yml`` is the file itself (the old form).
        ``InputFileError`` before anything is read if the file is one of the
        logs or ``config_path``.
    horizon : str, float or Horizon, optional
        Training horizon ``h_t``: a distance like ``"2m"`` (default 2 m) or a
        duration like ``"2s"``.
    eval_logs : sequence, optional
        Held-out logs: their errors per metre (and the ideal differential
        drive's) go into the report and the file.
    by_terrain : bool, optional
        One parameter set per terrain label of the training logs.
    options : FitOptions, optional
        Optimiser settings (Sigma, population, generations, seed).
    config, config_path : optional
        Configuration: wheel radius, nominal track width, evaluation horizon.

    Returns
    -------
    FitReport
    """
    try:
        m = get_model(model)
    except ValueError as exc:
        raise ConfigError(str(exc)) from None
    target = None if out is None else output_file(out, params_file_name(m.name), YAML_SUFFIXES)
    if out is not None and target is not None:
        check_out(out, YAML_SUFFIXES)
        check_outputs(_paths(logs, eval_logs, config_path), [target])
    cfg = config if config is not None else load_config(config_path)
    h_t = _horizon(horizon)
    timing: dict[str, TimeCalibration] = {}
    train = _load(logs, cfg, "training", timing)
    evals = _load(eval_logs, cfg, "evaluation", timing) if eval_logs else []
    opt = options or FitOptions()
    b = cfg.robot.track_width
    sets, fits, skipped = _fit_sets(m.name, train, h_t, by_terrain, opt, b, antenna_of(cfg))
    info: dict[str, Any] = {
        "wheel_radius": cfg.robot.wheel_radius,
        "pose_delay": _recorded_delay(timing),
        "horizon": str(h_t),
        "sigma": None if opt.sigma is None else np.asarray(opt.sigma, dtype=float).tolist(),
        "bounds": {
            n: [float(lo), float(hi)] for n, (lo, hi) in zip(m.param_names, m.bounds, strict=True)
        },
    }
    anchors = {log.source: log_anchor(log) for log in train}
    if set(anchors.values()) != {"pose"}:  # a GPS and an IMU: say what the segments ran between
        info["segments_between"] = anchors
    mp = ModelParams(m.name, sets, b, info)
    evaluation = _evaluate_fit(mp, evals, cfg, b) if evals else None
    if evaluation is not None:
        mp = ModelParams(m.name, sets, b, {**info, "evaluation": evaluation.to_dict()})
    if out is not None and target is not None:
        create_folder(out, YAML_SUFFIXES)
        with writing_into(out, target, "fit", [target.name], YAML_SUFFIXES):
            write_params(target, mp)
    return FitReport(mp, fits, skipped, evaluation, timing, target)


def _evaluate_fit(
    mp: ModelParams, evals: Sequence[WheelLog], cfg: Config, b: float
) -> FitEvaluation:
    """Held-out errors of the fitted model and of the ideal differential drive (``B = b``, m)."""
    h_e, antenna = cfg.evaluation.horizon, antenna_of(cfg)
    fitted = evaluate_params(mp, evals, h_e, b, antenna)
    ideal = evaluate_params(_idd(mp, b), evals, h_e, b, antenna)
    return FitEvaluation(
        horizon=h_e,
        logs=tuple(log.source for log in evals),
        groups={g: {mp.model: fitted[g], f"idd (B={b:g} m)": ideal[g]} for g in fitted},
    )


def format_error_stats(s: ErrorSummary) -> tuple[str, str]:
    """Return the per-metre errors as ``median [q25-q75]`` texts: m/m, deg/m (n/a: no window)."""
    t, r = s.translation, s.rotation
    if t.count == 0:
        return "n/a", "n/a"
    return (
        f"{t.median:.4f} [{t.q25:.3f}-{t.q75:.3f}]",
        f"{r.median:.3f} [{r.q25:.2f}-{r.q75:.2f}]",
    )


BOUND_MARK = "!"
"""Marks a parameter at or within 1 % of a search bound in the compare tables."""


def _fmt_params(model: str, ps: ParamSet, track_width: float) -> str:
    values = {**ps.params, **derived_quantities(model, ps.params, track_width)}
    short = {"steering_efficiency": "c", "eccentricity": "e"}
    return (
        ", ".join(
            f"{short.get(k, k)}={v:.3f}{BOUND_MARK if k in ps.at_bounds else ''}"
            for k, v in values.items()
        )
        or "-"
    )


def compare(
    logs: Sequence[LogSource],
    eval_logs: Sequence[LogSource],
    *,
    out_dir: str | Path | None = None,
    models: Sequence[str] | None = None,
    horizon: str | float | Horizon = DEFAULT_TRAINING_HORIZON,
    by_terrain: bool = False,
    options: FitOptions | None = None,
    config: Config | None = None,
    config_path: str | Path | None = None,
    dask: str | None = None,
) -> CompareReport:
    """Fit every model and tabulate parameters and held-out errors (Baril Table I, Fig. 5-6).

    Parameters
    ----------
    logs, eval_logs : sequence of str, Path or WheelLog
        Training and evaluation logs (with poses).
    out_dir : str or Path, optional
        Folder for ``compare.md``, ``compare.json``, ``compare.png`` and one
        ``params_<model>.yaml`` per model (created if missing);
        ``InputFileError`` before anything is read if one is an input.
    models : sequence of str, optional
        Models to compare (default: all of ``MODELS``; ``idd`` is only evaluated).
    horizon, by_terrain, options, config, config_path
        As for :func:`fit`.
    dask : str, optional
        Fit the models on this Dask cluster, one task per model
        (``tcp://host:port`` or ``local:N``, :func:`~terrain_odom.app.cluster.dask_cluster`);
        without it, one after the other in this process. The same parameters
        and errors either way (the fit times differ).

    Returns
    -------
    CompareReport
        The tables (``markdown``), per model its sets and held-out errors per
        group, and the settings.
    """
    names = list(models) if models is not None else list(MODELS)
    for name in names:
        if name not in MODELS:
            raise ConfigError(f"unknown kinematic model {name!r}; choose from {sorted(MODELS)}")
    files = [params_file_name(name) for name in names] + list(COMPARE_FILES)
    if out_dir is not None:
        check_outputs(_paths(logs, eval_logs, config_path), [Path(out_dir) / f for f in files])
    with writing_if(out_dir, "compare") as folder:  # locked; its own files replaced, no other
        if folder is not None:
            folder.prepare(files, overwrite=True, remove=False)
        report, raw_errors = _compare(
            logs, eval_logs, names, horizon, by_terrain, options, config, config_path, dask
        )
        if folder is None:
            return report
        folder.prepare(files, overwrite=True)
        return _write_compare(folder.path, report, raw_errors)


def _compare(
    logs: Sequence[LogSource],
    eval_logs: Sequence[LogSource],
    names: list[str],
    horizon: str | float | Horizon,
    by_terrain: bool,
    options: FitOptions | None,
    config: Config | None,
    config_path: str | Path | None,
    dask: str | None,
) -> tuple[CompareReport, dict[str, dict[str, list[WindowErrors]]]]:
    """Fit and evaluate the models of :func:`compare`: the report and the raw window errors."""
    cfg = config if config is not None else load_config(config_path)
    h_t = _horizon(horizon)
    timing: dict[str, TimeCalibration] = {}
    train = _load(logs, cfg, "training", timing)
    evals = _load(eval_logs, cfg, "evaluation", timing)
    opt = options or FitOptions()
    b = cfg.robot.track_width
    h_e = cfg.evaluation.horizon
    with dask_cluster(dask) as cluster:
        compared = run_jobs(
            _compare_model,
            names,
            cluster,
            train=train,
            evals=evals,
            horizon=h_t,
            by_terrain=by_terrain,
            options=opt,
            cfg=cfg,
        )
    results = {name: result for name, (result, _) in zip(names, compared, strict=True)}
    raw_errors = {name: raw for name, (_, raw) in zip(names, compared, strict=True)}
    report = CompareReport(
        training_logs=tuple(log.source for log in train),
        evaluation_logs=tuple(log.source for log in evals),
        horizon_train=h_t,
        horizon_eval=h_e,
        track_width=b,
        time_calibration=timing,
        models=results,
        markdown=_markdown(results, b, h_t, h_e),
    )
    return report, raw_errors


def _write_compare(
    target: Path, report: CompareReport, raw_errors: dict[str, dict[str, list[WindowErrors]]]
) -> CompareReport:
    """Write the files of :func:`compare` into ``target``; return the report naming them."""
    for name, result in report.models.items():
        write_params(target / params_file_name(name), result.params)
    md, js, png = (target / name for name in COMPARE_FILES)
    write_text_atomic(md, report.markdown)
    write_json(js, report.to_dict())
    values = {
        n: {g: error_values(e) for g, e in errors.items()} for n, errors in raw_errors.items()
    }
    fig = error_boxes_figure(values, report.horizon_eval, "Held-out model error")
    write_atomic(png, lambda handle: save_png(fig, handle))
    params = tuple(target / params_file_name(name) for name in report.models)
    return dataclasses.replace(report, outputs=(md, js, png, *params))


def _compare_model(
    name: str,
    *,
    train: Sequence[WheelLog],
    evals: Sequence[WheelLog],
    horizon: Horizon,
    by_terrain: bool,
    options: FitOptions,
    cfg: Config,
) -> tuple[ModelComparison, dict[str, list[WindowErrors]]]:
    """Fit one model of :func:`compare` and its held-out window errors per group (a joblib task)."""
    b = cfg.robot.track_width
    sets, _, skipped = _fit_sets(name, train, horizon, by_terrain, options, b, antenna_of(cfg))
    mp = ModelParams(
        name, sets, b, {"wheel_radius": cfg.robot.wheel_radius, "horizon": str(horizon)}
    )
    raw = _group_errors(mp, evals, cfg.evaluation.horizon, b, antenna_of(cfg))
    errors = {g: summarize(e) for g, e in raw.items()}
    return ModelComparison(mp, skipped, errors), raw


def _markdown(
    results: dict[str, ModelComparison], track_width: float, h_t: Horizon, h_e: float
) -> str:
    groups = sorted({g for r in results.values() for g in r.params.sets})
    head = [g if g != ANY_TERRAIN else "all training logs" for g in groups]
    param_rows = []
    for name, result in results.items():
        sets = result.params.sets
        cells = [_fmt_params(name, sets[g], track_width) if g in sets else "-" for g in groups]
        if name == "idd":
            cells = [f"B={track_width:g} m (not fitted)"] * len(groups)
        param_rows.append([name, *cells])
    error_rows = []
    for name, result in results.items():
        for g, summary in sorted(result.errors.items()):
            t, r = format_error_stats(summary)
            ps = result.params.sets.get(g, result.params.sets.get(ANY_TERRAIN))
            fit_s = 0.0 if ps is None else ps.fit.get("seconds", 0.0)
            error_rows.append([name, g, summary.translation.count, t, r, f"{fit_s:.1f}"])
    lines = [
        f"Parameters per model and terrain (trained on h_t = {h_t} segments; "
        f"c = (y_l - y_r) / B with B = {track_width:g} m, e = eccentricity; "
        f"{BOUND_MARK}: at or within 1 % of a search bound)",
        "",
        table(["model", *head], param_rows),
        "",
        f"Held-out error per metre over h_e = {h_e:g} m windows: median [q25-q75]",
        "",
        table(["model", "terrain", "windows", "m/m", "deg/m", "fit (s)"], error_rows),
    ]
    return "\n".join(lines) + "\n"
