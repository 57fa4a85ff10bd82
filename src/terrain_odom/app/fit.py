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
from terrain_odom.app.inputs import LogSource, choose_config, read_pose_logs
from terrain_odom.app.locate import check_out, create_folder, output_file, writing_into
from terrain_odom.app.model_fits import evaluate_params, fit_sets, group_errors
from terrain_odom.config import Config
from terrain_odom.errors import ConfigError
from terrain_odom.estimation.time_offset import TimeCalibration
from terrain_odom.evaluation import (
    ErrorSummary,
    WindowErrors,
    antenna_of,
    log_anchor,
    summarize,
)
from terrain_odom.fitting import (
    DEFAULT_TRAINING_HORIZON,
    FitOptions,
    FitResult,
    Horizon,
    parse_horizon,
)
from terrain_odom.fitting.params import ANY_TERRAIN, ModelParams, ParamSet, derived_quantities
from terrain_odom.io.atomic import write_atomic, write_text_atomic
from terrain_odom.io.folder import writing_if
from terrain_odom.io.params import write_params
from terrain_odom.io.paths import check_outputs
from terrain_odom.io.report import write_json
from terrain_odom.kinematics import MODELS, get_model
from terrain_odom.records import WheelLog
from terrain_odom.reporting.figure import save_png
from terrain_odom.reporting.model_errors import error_boxes_figure, error_values
from terrain_odom.reporting.tables import compare_markdown, format_params

__all__ = [
    "FitEvaluation",
    "FitReport",
    "ModelComparison",
    "CompareReport",
    "fit",
    "compare",
    "params_file_name",
    "YAML_SUFFIXES",
]

COMPARE_FILES = ("compare.md", "compare.json", "compare.png")
"""Files :func:`compare` writes into its ``out_dir`` (besides ``params_MODEL.yaml``)."""
YAML_SUFFIXES = (".yaml", ".yml")
"""Suffixes by which :func:`fit`'s ``out_dir`` names the parameter file itself (the old form)."""


def params_file_name(model: str) -> str:
    """Return the name of a model's parameter file in an output folder: ``params_<model>.yaml``."""
    return f"params_{model}.yaml"


def group_name(group: str) -> str:
    """Return how reports name a group of windows: its terrain, or ``all`` for :data:`ANY_TERRAIN`."""
    return "all" if group == ANY_TERRAIN else group


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
        Per group (terrain, or ``ANY_TERRAIN`` without per-terrain sets), per
        model name: pooled error statistics.
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
                group_name(g): {name: s.to_dict() for name, s in models.items()}
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
        ideal differential drive, per group (terrain or ``ANY_TERRAIN``).
    time_calibration : dict of str to TimeCalibration
        Per log (its ``source``): the pose delay applied (see
        ``config.time.pose_delay``).
    output : Path or None
        The parameter file written (None without ``out_dir``).
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
        Held-out error statistics per group (terrain or ``ANY_TERRAIN``).
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
            "errors": {group_name(g): e.to_dict() for g, e in self.errors.items()},
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


def _horizon(value: str | float | Horizon) -> Horizon:
    if isinstance(value, Horizon):
        return value
    try:
        return parse_horizon(value)
    except ValueError as exc:
        raise ConfigError(str(exc)) from None


def _idd(mp: ModelParams, track_width: float) -> ModelParams:
    """Return the ideal differential drive with the same grouping as ``mp``."""
    return ModelParams("idd", {k: ParamSet({}) for k in mp.sets}, track_width)


def fit(
    logs: Sequence[LogSource],
    model: str,
    *,
    out_dir: str | Path | None = None,
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
    out_dir : str or Path, optional
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
    target = (
        None if out_dir is None else output_file(out_dir, params_file_name(m.name), YAML_SUFFIXES)
    )
    if out_dir is not None and target is not None:
        check_out(out_dir, YAML_SUFFIXES)
        check_outputs(_paths(logs, eval_logs, config_path), [target])
    config = choose_config(config, config_path).config
    h_t = _horizon(horizon)
    timing: dict[str, TimeCalibration] = {}
    train = read_pose_logs(logs, config, "training", timing)
    evals = read_pose_logs(eval_logs, config, "evaluation", timing) if eval_logs else []
    opt = options or FitOptions()
    b = config.robot.track_width
    sets, fits, skipped = fit_sets(m.name, train, h_t, by_terrain, opt, b, antenna_of(config))
    info: dict[str, Any] = {
        "wheel_radius": config.robot.wheel_radius,
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
    evaluation = _evaluate_fit(mp, evals, config, b) if evals else None
    if evaluation is not None:
        mp = ModelParams(m.name, sets, b, {**info, "evaluation": evaluation.to_dict()})
    if out_dir is not None and target is not None:
        create_folder(out_dir, YAML_SUFFIXES)
        with writing_into(out_dir, target, "fit", [target.name], YAML_SUFFIXES):
            write_params(target, mp)
    return FitReport(mp, fits, skipped, evaluation, timing, target)


def _evaluate_fit(
    mp: ModelParams, evals: Sequence[WheelLog], config: Config, b: float
) -> FitEvaluation:
    """Held-out errors of the fitted model and of the ideal differential drive (``B = b``, m)."""
    h_e, antenna = config.evaluation.horizon, antenna_of(config)
    fitted = evaluate_params(mp, evals, h_e, b, antenna)
    ideal = evaluate_params(_idd(mp, b), evals, h_e, b, antenna)
    return FitEvaluation(
        horizon=h_e,
        logs=tuple(log.source for log in evals),
        groups={g: {mp.model: fitted[g], f"idd (B={b:g} m)": ideal[g]} for g in fitted},
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
    config = choose_config(config, config_path).config
    h_t = _horizon(horizon)
    timing: dict[str, TimeCalibration] = {}
    train = read_pose_logs(logs, config, "training", timing)
    evals = read_pose_logs(eval_logs, config, "evaluation", timing)
    opt = options or FitOptions()
    b = config.robot.track_width
    h_e = config.evaluation.horizon
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
            config=config,
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
    config: Config,
) -> tuple[ModelComparison, dict[str, list[WindowErrors]]]:
    """Fit one model of :func:`compare` and its held-out window errors per group (a joblib task)."""
    b = config.robot.track_width
    sets, _, skipped = fit_sets(name, train, horizon, by_terrain, options, b, antenna_of(config))
    mp = ModelParams(
        name, sets, b, {"wheel_radius": config.robot.wheel_radius, "horizon": str(horizon)}
    )
    raw = group_errors(mp, evals, config.evaluation.horizon, b, antenna_of(config))
    errors = {g: summarize(e) for g, e in raw.items()}
    return ModelComparison(mp, skipped, errors), raw


def _markdown(
    results: dict[str, ModelComparison], track_width: float, h_t: Horizon, h_e: float
) -> str:
    """Return ``compare.md`` (:func:`~terrain_odom.reporting.tables.compare_markdown`)."""
    groups = sorted({g for r in results.values() for g in r.params.sets})
    head = [g if g != ANY_TERRAIN else "all training logs" for g in groups]
    param_rows = []
    for name, result in results.items():
        mp = result.params
        cells = [
            format_params({**ps.params, **derived_quantities(name, ps.params, track_width)},
                          ps.at_bounds)
            if (ps := mp.sets.get(g)) is not None else "-"
            for g in groups
        ]  # fmt: skip
        if name == "idd":
            cells = [f"B={track_width:g} m (not fitted)"] * len(groups)
        param_rows.append([name, *cells])
    error_rows = []
    for name, result in results.items():
        for g, summary in sorted(result.errors.items()):
            ps = result.params.sets.get(g, result.params.sets.get(ANY_TERRAIN))
            fit_s = 0.0 if ps is None else ps.fit.get("seconds", 0.0)
            error_rows.append((name, group_name(g), summary, fit_s))
    return compare_markdown(head, param_rows, error_rows, track_width, str(h_t), h_e)
