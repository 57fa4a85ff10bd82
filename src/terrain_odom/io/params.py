"""Parameter files of constant kinematic models (YAML).

Version 2 (written by ``terrain-odom fit``)::

    format_version: 2
    model: edd-asym           # a name from terrain_odom.kinematics.MODELS
    track_width: 1.08         # m: nominal B (models that need it; steering efficiency)
    horizon: 2m               # training horizon h_t (informational)
    sigma: [1.0, 1.0, 1.0]    # loss Sigma as standard deviations m, m, rad (informational)
    bounds: {alpha_l: [0.0, 1.5], ...}       # search bounds (informational)
    params: {alpha_l: 0.93, ...}              # one set for every terrain ...
    fit: {loss: 14.2, segments: 83, length_m: 190.0, duration_s: 647.0, seconds: 2.8}
    derived: {steering_efficiency: 1.71, eccentricity: 0.2}   # ICR models, informational
    evaluation: {...}         # with --eval: error statistics (informational)

or, instead of ``params``/``fit``/``derived``, one set per terrain label::

    terrains:
      grass:   {params: {...}, fit: {...}, derived: {...}}
      asphalt: {params: {...}, fit: {...}, derived: {...}}

A file reads as :class:`~terrain_odom.fitting.params.ModelParams` (the fit
result); for ``icr`` and ``icr-slip`` files its
:meth:`~terrain_odom.fitting.params.ModelParams.icr` gives each terrain's
``(y_l, y_r, x_icr, alpha)``: the values that can seed the ICR EKF.
Version 1 files (``format_version, model, params, track_width`` only) are
still read. Unknown keys and parameters are rejected with the file and key
named; the informational entries are checked for shape only.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np
import yaml

from terrain_odom.config import RobotConfig
from terrain_odom.config.loader import read_yaml
from terrain_odom.errors import InputFileError
from terrain_odom.estimation.icr_ekf import IcrPriors
from terrain_odom.fitting.params import (
    ANY_TERRAIN,
    ModelParams,
    ParamSet,
    check_geometry,
    check_sets,
    derived_quantities,
    icr_priors,
)
from terrain_odom.io.atomic import write_atomic
from terrain_odom.kinematics import get_model

__all__ = [
    "PARAMS_FORMAT_VERSION",
    "read_params",
    "read_priors",
    "write_params",
]

PARAMS_FORMAT_VERSION = 2
_V1_KEYS = {"format_version", "model", "params", "track_width"}
_INFO_KEYS = {"horizon", "sigma", "bounds", "evaluation", "wheel_radius", "pose_delay"}
_SET_KEYS = {"params", "fit", "derived", "at_bounds"}
_V2_KEYS = _V1_KEYS | _INFO_KEYS | _SET_KEYS | {"terrains"}
_FIT_KEYS = ("loss", "segments", "length_m", "duration_s", "seconds")


def _number(value: object, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        raise InputFileError(f"{where}: must be a finite number, got {value!r}")
    return float(value)


def _mapping(value: object, where: str) -> dict:
    if not isinstance(value, dict):
        raise InputFileError(f"{where}: expected a mapping, got {value!r}")
    return value


def _read_set(data: dict, names: tuple[str, ...], where: str, model: str) -> ParamSet:
    raw = data.get("params") or {}
    if not isinstance(raw, dict) or set(map(str, raw)) != set(names):
        raise InputFileError(
            f"{where}: model {model!r} needs params {list(names)}, "
            f"got {sorted(map(str, raw)) if isinstance(raw, dict) else raw!r}"
        )
    params = {str(k): _number(v, f"{where}: params.{k}") for k, v in raw.items()}
    fit = _mapping(data.get("fit") or {}, f"{where}: fit")
    unknown = sorted(set(map(str, fit)) - set(_FIT_KEYS))
    if unknown:
        raise InputFileError(f"{where}: fit: unknown key(s) {unknown}; allowed: {list(_FIT_KEYS)}")
    _mapping(data.get("derived") or {}, f"{where}: derived")
    bounded = data.get("at_bounds") or []
    if not isinstance(bounded, list) or not set(map(str, bounded)) <= set(names):
        raise InputFileError(f"{where}: at_bounds must list parameter names of {list(names)}")
    fitted = {str(k): _number(v, f"{where}: fit.{k}") for k, v in fit.items()}
    return ParamSet(params, fitted, tuple(map(str, bounded)))


def read_params(path: str | Path) -> ModelParams:
    """Read and validate a parameter file (version 1 or 2).

    Raises
    ------
    InputFileError
        If the file is missing, not YAML, or has unknown/missing keys.
    """
    path = Path(path)
    data = read_yaml(path, kind="parameter file", error=InputFileError)
    if not isinstance(data, dict):
        raise InputFileError(f"{path}: expected a mapping with keys {sorted(_V2_KEYS)}")
    version = data.get("format_version")
    if version not in (1, PARAMS_FORMAT_VERSION):
        raise InputFileError(
            f"{path}: format_version {version!r} is not supported (expected 1 or "
            f"{PARAMS_FORMAT_VERSION})"
        )
    allowed = _V1_KEYS if version == 1 else _V2_KEYS
    unknown = sorted(set(map(str, data)) - allowed)
    if unknown:
        raise InputFileError(f"{path}: unknown key(s) {unknown}; allowed: {sorted(allowed)}")
    try:
        model = get_model(str(data.get("model")))
    except ValueError as exc:
        raise InputFileError(f"{path}: {exc}") from None
    if "terrains" in data:
        if set(data) & _SET_KEYS:
            raise InputFileError(
                f"{path}: give either 'terrains' or top-level {sorted(_SET_KEYS)}, not both"
            )
        terrains = _mapping(data["terrains"], f"{path}: terrains")
        if not terrains:
            raise InputFileError(f"{path}: terrains: no parameter set")
        sets = {
            str(name): _read_set(
                _mapping(entry, f"{path}: terrains.{name}"),
                model.param_names,
                f"{path}: terrains.{name}",
                model.name,
            )
            for name, entry in terrains.items()
        }
    else:
        sets = {ANY_TERRAIN: _read_set(data, model.param_names, str(path), model.name)}
    b = data.get("track_width")
    track_width = None if b is None else _number(b, f"{path}: track_width")
    if track_width is not None and track_width <= 0:
        raise InputFileError(f"{path}: track_width must be > 0 m, got {track_width}")
    info = {k: data[k] for k in sorted(_INFO_KEYS) if k in data}
    params = ModelParams(model.name, sets, track_width, info)
    check_sets(params, _bounds(params.info.get("bounds"), model.param_names, path), path)
    return params


def _bounds(value: object, names: tuple[str, ...], path: Path) -> list[tuple[float, float]] | None:
    """Return the file's ``bounds`` per parameter (None if it records none)."""
    if value is None:
        return None
    bounds = _mapping(value, f"{path}: bounds")
    pairs = []
    for name in names:
        pair = bounds.get(name)
        if not isinstance(pair, list) or len(pair) != 2:
            raise InputFileError(f"{path}: bounds.{name}: expected [low, high], got {pair!r}")
        lo, hi = (_number(v, f"{path}: bounds.{name}") for v in pair)
        if not lo < hi:
            raise InputFileError(f"{path}: bounds.{name}: low {lo:g} is not below high {hi:g}")
        pairs.append((lo, hi))
    return pairs


def _set_entry(mp: ModelParams, ps: ParamSet) -> dict[str, Any]:
    entry: dict[str, Any] = {"params": {k: float(v) for k, v in ps.params.items()}}
    if ps.fit:
        entry["fit"] = {k: ps.fit[k] for k in _FIT_KEYS if k in ps.fit}
    derived = derived_quantities(mp.model, ps.params, mp.track_width)
    if derived:
        entry["derived"] = derived
    if ps.at_bounds:
        entry["at_bounds"] = list(ps.at_bounds)
    return entry


def _plain(value: Any) -> Any:
    """Numpy scalars and tuples to plain YAML types; NaN to None."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(v) for v in value]
    if isinstance(value, (np.integer, np.floating)):
        value = value.item()
    if isinstance(value, float) and math.isnan(value):
        return None
    return value


def write_params(path: str | Path, mp: ModelParams) -> None:
    """Write a version-2 parameter file atomically (derived ``c``, ``e`` recomputed)."""
    data: dict[str, Any] = {
        "format_version": PARAMS_FORMAT_VERSION,
        "model": mp.model,
    }
    if mp.track_width is not None:
        data["track_width"] = float(mp.track_width)
    data.update(
        {
            k: mp.info[k]
            for k in ("wheel_radius", "pose_delay", "horizon", "sigma", "bounds")
            if k in mp.info
        }
    )
    if mp.per_terrain:
        data["terrains"] = {name: _set_entry(mp, ps) for name, ps in mp.sets.items()}
    else:
        data.update(_set_entry(mp, mp.sets[ANY_TERRAIN]))
    if "evaluation" in mp.info:
        data["evaluation"] = mp.info["evaluation"]
    text = yaml.safe_dump(_plain(data), sort_keys=False, default_flow_style=None, width=100)

    def write(handle: BinaryIO) -> None:
        handle.write(text.encode("utf-8"))

    write_atomic(path, write)


def read_priors(path: str | Path, robot: RobotConfig | None = None) -> IcrPriors:
    """Read a parameter file of ``terrain-odom fit --model icr|icr-slip`` as EKF priors.

    Parameters
    ----------
    path : str or Path
        The parameter file.
    robot : RobotConfig, optional
        The geometry in use, checked against the file's (:func:`check_geometry`).

    Raises
    ------
    InputFileError
        If the file is missing or malformed, or its model has no ICR state.
    ConfigError
        If it was fitted with another robot geometry.
    """
    params = read_params(path)
    if robot is not None:
        check_geometry(params, robot.wheel_radius, robot.track_width, path)
    try:
        return icr_priors(params)
    except ValueError as exc:
        raise InputFileError(f"{path}: {exc}") from None
