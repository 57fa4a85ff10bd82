"""Parameter files of constant kinematic models (YAML).

Layout (``format_version: 1``)::

    format_version: 1
    model: edd-sym            # a name from terrain_odom.kinematics.MODELS
    params: {alpha: 0.91, b_hat: 1.78}
    track_width: 1.08         # m, only for models that need the nominal B

Unknown keys and parameters are rejected with the file and key named.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from terrain_odom.errors import InputFileError
from terrain_odom.kinematics import get_model

__all__ = ["ModelParams", "read_params", "PARAMS_FORMAT_VERSION"]

PARAMS_FORMAT_VERSION = 1
_KEYS = {"format_version", "model", "params", "track_width"}


@dataclass(frozen=True)
class ModelParams:
    """A constant kinematic model: its name, parameter values and ``B`` (m)."""

    model: str
    params: dict[str, float]
    track_width: float | None = None

    def vector(self) -> np.ndarray:
        """Parameter values in the model's order, shape (k,)."""
        return np.array([self.params[n] for n in get_model(self.model).param_names], dtype=float)


def _number(value: object, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        raise InputFileError(f"{where}: must be a finite number, got {value!r}")
    return float(value)


def read_params(path: str | Path) -> ModelParams:
    """Read and validate a parameter file.

    Raises
    ------
    InputFileError
        If the file is missing, not YAML, or has unknown/missing keys.
    """
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputFileError(f"{path}: parameter file not found") from None
    except yaml.YAMLError:
        raise InputFileError(f"{path}: not valid YAML") from None
    if not isinstance(data, dict):
        raise InputFileError(f"{path}: expected a mapping with keys {sorted(_KEYS)}")
    unknown = sorted(set(map(str, data)) - _KEYS)
    if unknown:
        raise InputFileError(f"{path}: unknown key(s) {unknown}; allowed: {sorted(_KEYS)}")
    version = data.get("format_version")
    if version != PARAMS_FORMAT_VERSION:
        raise InputFileError(
            f"{path}: format_version {version!r} is not supported (expected {PARAMS_FORMAT_VERSION})"
        )
    try:
        model = get_model(str(data.get("model")))
    except ValueError as exc:
        raise InputFileError(f"{path}: {exc}") from None
    raw = data.get("params") or {}
    if not isinstance(raw, dict) or set(map(str, raw)) != set(model.param_names):
        raise InputFileError(
            f"{path}: model {model.name!r} needs params {list(model.param_names)}, "
            f"got {sorted(map(str, raw)) if isinstance(raw, dict) else raw!r}"
        )
    params = {str(k): _number(v, f"{path}: params.{k}") for k, v in raw.items()}
    b = data.get("track_width")
    track_width = None if b is None else _number(b, f"{path}: track_width")
    if model.needs_track_width and track_width is not None and track_width <= 0:
        raise InputFileError(f"{path}: track_width must be > 0 m, got {track_width}")
    return ModelParams(model.name, params, track_width)
