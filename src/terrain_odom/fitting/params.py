"""Fit results: a constant kinematic model's parameter sets, one per terrain or one for all.

What ``terrain-odom fit`` finds (:class:`ModelParams`, a :class:`ParamSet`
per terrain label or :data:`ANY_TERRAIN`), the ICR EKF's priors they give
(:func:`icr_priors`), and the checks a set must pass against the bounds it
was fitted in (:func:`check_sets`) and the robot it is used on
(:func:`check_geometry`). The file format is :mod:`terrain_odom.io.params`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from terrain_odom.config import IcrState
from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.estimation.icr_ekf import IcrPriors
from terrain_odom.fitting.identify import at_bounds
from terrain_odom.kinematics import eccentricity, get_model, steering_efficiency
from terrain_odom.records import WheelLog

__all__ = [
    "ANY_TERRAIN",
    "GEOMETRY_RTOL",
    "ParamSet",
    "ModelParams",
    "check_geometry",
    "check_sets",
    "derived_quantities",
    "icr_priors",
]

ANY_TERRAIN = "*"
"""Key of the one parameter set for every terrain in :attr:`ModelParams.sets` (a file
without per-terrain sets holds that set at its top level)."""


@dataclass(frozen=True)
class ParamSet:
    """One fitted parameter set and what the fit reported about it.

    Attributes
    ----------
    params : dict of str to float
        Parameter values by name.
    fit : dict of str to float
        Training figures (``loss``, ``segments``, ``length_m``, ``duration_s``,
        ``seconds``); empty for hand-written files.
    at_bounds : tuple of str
        Parameters the fit left at or within 1 % of a search bound (the data
        do not determine them, or the optimum lies beyond the bound).
    """

    params: dict[str, float]
    fit: dict[str, float] = field(default_factory=dict)
    at_bounds: tuple[str, ...] = ()


@dataclass(frozen=True)
class ModelParams:
    """A constant kinematic model: parameter sets, one per terrain or one for all.

    Attributes
    ----------
    model : str
        Model name.
    sets : dict of str to ParamSet
        By terrain label, or ``{ANY_TERRAIN: set}``.
    track_width : float, optional
        Nominal track width ``B``, m.
    info : dict
        Entries about the fit: ``wheel_radius`` (m) and ``pose_delay`` (s, or
        per log) the logs were read with, ``horizon``, ``sigma``, ``bounds``,
        ``evaluation``.
    """

    model: str
    sets: dict[str, ParamSet]
    track_width: float | None = None
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def per_terrain(self) -> bool:
        """Whether the file holds one set per terrain label."""
        return ANY_TERRAIN not in self.sets

    def vector(self, terrain: str | None = None) -> np.ndarray:
        """Parameter values in the model's order, shape (k,).

        Raises
        ------
        KeyError
            For a per-terrain file, if ``terrain`` is None or has no set.
        """
        if not self.per_terrain:
            chosen = self.sets[ANY_TERRAIN]
        elif terrain in self.sets:
            chosen = self.sets[terrain]
        else:
            raise KeyError(
                f"no {self.model} parameters for terrain {terrain!r}; "
                f"the file has {sorted(self.sets)}"
            )
        names = get_model(self.model).param_names
        return np.array([chosen.params[n] for n in names], dtype=float)

    def rows(self, log: WheelLog) -> np.ndarray:
        """Parameters of every row of a log: its terrain's set, shape (N, k).

        Raises
        ------
        InputFileError
            If the file is per terrain and the log has no terrain column or a
            terrain without a set.
        """
        k = len(get_model(self.model).param_names)
        if not self.per_terrain:
            return np.broadcast_to(self.vector(), (len(log), k))
        if log.terrain is None:
            raise InputFileError(
                f"{log.source}: no terrain column, but the {self.model} parameters are per "
                f"terrain ({sorted(self.sets)})"
            )
        labels, inverse = np.unique(log.terrain, return_inverse=True)
        try:
            table = np.array([self.vector(str(label)) for label in labels]).reshape(labels.size, k)
        except KeyError as exc:
            raise InputFileError(f"{log.source}: {exc.args[0]}") from None
        return table[inverse.ravel()]

    def icr(self, terrain: str | None = None) -> tuple[float, float, float, float]:
        """``(y_l, y_r, x_icr, alpha)`` of an ``icr`` or ``icr-slip`` set (EKF seed).

        ``alpha`` is 1 for the ``icr`` model.
        """
        if self.model not in ("icr", "icr-slip"):
            raise ValueError(f"model {self.model!r} has no ICR state; fit 'icr' or 'icr-slip'")
        v = self.vector(terrain)
        return float(v[0]), float(v[1]), float(v[2]), float(v[3]) if v.size > 3 else 1.0


def derived_quantities(
    model: str, params: Mapping[str, float], track_width: float | None
) -> dict[str, float]:
    """Steering efficiency ``c`` and eccentricity ``e`` of models with track ICRs.

    Returns an empty dict for models without ``y_l, y_r`` (and ``c`` only
    with a ``track_width``).
    """
    names = get_model(model).param_names
    if "y_l" not in names or "y_r" not in names:
        return {}
    y_l, y_r = params["y_l"], params["y_r"]
    out = {"eccentricity": float(eccentricity(y_l, y_r))}
    if track_width is not None:
        out = {"steering_efficiency": float(steering_efficiency(y_l, y_r, track_width)), **out}
    return out


def check_sets(
    params: ModelParams, limits: Sequence[tuple[float, float]] | None, path: str | Path
) -> None:
    """Refuse sets their file contradicts: outside its bounds, a false ``at_bounds``, y_l <= y_r.

    Parameters
    ----------
    params : ModelParams
        The sets as read.
    limits : sequence of (float, float), optional
        The search bounds the file records, per parameter in the model's
        order (None: it records none).
    path : str or Path
        The file, for the messages.

    Raises
    ------
    InputFileError
        Naming the set, the parameter and the file's own figures.
    """
    model = get_model(params.model)
    for label, ps in params.sets.items():
        where = f"{path}: " + (f"terrains.{label}." if params.per_terrain else "")
        if {"y_l", "y_r"} <= set(ps.params) and not ps.params["y_l"] > 0.0 > ps.params["y_r"]:
            raise InputFileError(
                f"{where}params: the ICRs need y_l > 0 > y_r, got y_l={ps.params['y_l']:.6g}, "
                f"y_r={ps.params['y_r']:.6g} (edited by hand? swapped sides?)"
            )
        if limits is None:
            continue
        for name, (lo, hi) in zip(model.param_names, limits, strict=True):
            if not lo <= ps.params[name] <= hi:
                raise InputFileError(
                    f"{where}params.{name}: {ps.params[name]:.6g} lies outside its bounds "
                    f"[{lo:g}, {hi:g}] recorded in the file (edited by hand?)"
                )
        vector = np.array([ps.params[name] for name in model.param_names])
        flagged = at_bounds(model, vector, limits)
        if set(flagged) != set(ps.at_bounds):
            raise InputFileError(
                f"{where}at_bounds: says {sorted(ps.at_bounds)}, but the parameters at a bound "
                f"are {sorted(flagged)} (edited by hand?)"
            )


def icr_priors(params: ModelParams) -> IcrPriors:
    """Priors of the ICR EKF from a parameter file of ``terrain-odom fit --model icr|icr-slip``.

    A per-terrain file (``--by-terrain``) gives
    :attr:`~terrain_odom.estimation.icr_ekf.IcrPriors.terrains`, a file with
    one set :attr:`~terrain_odom.estimation.icr_ekf.IcrPriors.start`.
    ``alpha`` is 1 for the ``icr`` model.

    Raises
    ------
    ValueError
        If the model has no ICR state, or a set has not ``y_l > 0 > y_r``.
    """
    states = {label: IcrState(*params.icr(label)) for label in params.sets}
    for label, s in states.items():
        if not s.y_l > 0.0 > s.y_r:
            where = f"terrain {label!r}" if params.per_terrain else "the parameter set"
            raise ValueError(f"{where} needs y_l > 0 > y_r, got y_l={s.y_l}, y_r={s.y_r}")
    if params.per_terrain:
        return IcrPriors(terrains=states)
    return IcrPriors(start=next(iter(states.values())))


GEOMETRY_RTOL = 1e-6
"""Relative difference below which two robot sizes are the same (1 um on a metre)."""


def check_geometry(
    params: ModelParams, wheel_radius: float, track_width: float, path: str | Path
) -> None:
    """Refuse a parameter file fitted with another robot geometry than the one in use.

    Raises
    ------
    ConfigError
        The file's ``wheel_radius`` or ``track_width`` (where recorded) differs
        from the configuration's by more than :data:`GEOMETRY_RTOL` (relative);
        the message names both, with every digit they differ in.
    """
    recorded = {"wheel_radius": params.info.get("wheel_radius"), "track_width": params.track_width}
    used = {"wheel_radius": wheel_radius, "track_width": track_width}
    for name, value in recorded.items():
        if value is not None and not math.isclose(float(value), used[name], rel_tol=GEOMETRY_RTOL):
            raise ConfigError(
                f"{path}: fitted with robot.{name} {float(value)!r} m, but the configuration in "
                f"use says {float(used[name])!r} m: give the configuration it was fitted with "
                "(--config)"
            )
