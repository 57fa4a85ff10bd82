"""Fit a constant kinematic model on training segments (Baril et al.; Martinez et al.).

The loss (:mod:`terrain_odom.fitting.loss`, Baril et al. eq. 13) is
summed over the training segments (:mod:`terrain_odom.fitting.segments`).
The search is global and derivative-free, inside the model's bounds (Baril
Table I, made finite): :func:`scipy.optimize.differential_evolution`, an
evolutionary optimiser like Martinez' genetic algorithm, with the whole
population integrated over all segments at once; its best member is then
polished by bounded least squares on the whitened residuals.

References
----------
.. [1] Baril et al., "Evaluation of Skid-Steering Kinematic Models for
   Subarctic Environments", CRV 2020, eq. 13 and Table I.
.. [2] Martinez et al., "Kinematic Modelling of Tracked Vehicles by
   Experimental Identification", IROS 2004, section IV.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import differential_evolution, least_squares

from terrain_odom.errors import EstimationError
from terrain_odom.fitting.loss import residuals, squared_loss, whitener_matrix
from terrain_odom.fitting.segments import SegmentSet
from terrain_odom.kinematics.models import KinematicModel, get_model

__all__ = ["FitOptions", "FitResult", "fit_model", "at_bounds"]


@dataclass(frozen=True)
class FitOptions:
    """Settings of the optimiser.

    Attributes
    ----------
    sigma : array_like or None
        ``Sigma`` of the loss: 3 standard deviations (m, m, rad) or a 3x3
        covariance; identity if None (Baril et al.).
    popsize : int
        Population size multiplier of differential evolution (``popsize * k`` members).
    maxiter : int
        Maximum number of generations.
    tol : float
        Relative convergence tolerance of differential evolution.
    seed : int
        Seed of the optimiser's random generator (fits are reproducible).
    polish : bool
        Polish the best member with bounded least squares.
    """

    sigma: tuple[float, float, float] | np.ndarray | None = None
    popsize: int = 15
    maxiter: int = 300
    tol: float = 1e-3
    seed: int = 0
    polish: bool = True


@dataclass(frozen=True)
class FitResult:
    """A fitted constant model.

    Attributes
    ----------
    model : str
        Model name.
    params : ndarray, shape (k,)
        Parameters in ``get_model(model).param_names`` order.
    loss : float
        Training loss (eq. 13) at ``params``.
    segments : int
        Number of training segments ``N``.
    length, duration : float
        Total training path length (m) and duration (s).
    seconds : float
        Wall time of the fit, s.
    generations, evaluations : int
        Differential-evolution generations, and parameter sets evaluated in
        all (the population of each generation, each polishing step).
    at_bounds : tuple of str
        Parameters at or within 1 % of a search bound (:func:`at_bounds`):
        the optimum may lie beyond it, or the data do not determine them.
    """

    model: str
    params: np.ndarray
    loss: float
    segments: int
    length: float
    duration: float
    seconds: float
    generations: int
    evaluations: int
    at_bounds: tuple[str, ...] = ()

    def as_dict(self) -> dict[str, float]:
        """Parameters by name."""
        names = get_model(self.model).param_names
        return {n: float(v) for n, v in zip(names, self.params, strict=True)}


def fit_model(
    model: KinematicModel | str,
    segments: SegmentSet,
    *,
    options: FitOptions | None = None,
    track_width: float | None = None,
) -> FitResult:
    """Fit a constant kinematic model on training segments.

    Parameters
    ----------
    model : KinematicModel or str
        The model or its name.
    segments : SegmentSet
        Training segments (:func:`segment_set`); at least one.
    options : FitOptions, optional
        Optimiser settings.
    track_width : float, optional
        Nominal ``B``, m, for models that need it (idd, roc).

    Returns
    -------
    FitResult

    Raises
    ------
    ValueError
        Without segments, or for a bad ``Sigma``.
    """
    started = time.perf_counter()
    m = get_model(model) if isinstance(model, str) else model
    opt = options or FitOptions()
    if segments.count == 0:
        raise ValueError("no training segment: the logs never reach the horizon")
    whitener = whitener_matrix(opt.sigma)
    evaluated = [0]  # parameter sets evaluated (scipy counts a vectorised call as one)

    def loss(pop: np.ndarray) -> np.ndarray:
        evaluated[0] += pop.shape[0]
        return squared_loss(residuals(m, pop, segments, whitener=whitener, track_width=track_width))

    k = len(m.param_names)
    if k:
        _check_excitation(m.name, segments, track_width)
    if k == 0:
        x = np.zeros(0)
        return FitResult(
            m.name, x, float(loss(x[None])[0]), segments.count, segments.length,
            segments.duration, time.perf_counter() - started, 0, evaluated[0],
        )  # fmt: skip
    de = differential_evolution(
        lambda pop_t: loss(pop_t.T),  # scipy passes the population as (k, S)
        bounds=m.bounds,
        popsize=opt.popsize,
        maxiter=opt.maxiter,
        tol=opt.tol,
        seed=opt.seed,  # scipy >= 1.10 (rng= only exists from 1.15)
        polish=False,
        vectorized=True,
        updating="deferred",
        workers=1,
    )
    x, best = np.asarray(de.x, dtype=float), float(de.fun)
    if opt.polish:
        lo, hi = np.array(m.bounds, dtype=float).T

        def flat(q: np.ndarray) -> np.ndarray:
            evaluated[0] += 1
            res = residuals(m, q[None], segments, whitener=whitener, track_width=track_width)
            return np.nan_to_num(res.ravel(), nan=1e6, posinf=1e6, neginf=-1e6)

        ls = least_squares(
            flat,
            np.clip(x, lo, hi),
            bounds=(lo, hi),
            x_scale="jac",
        )
        polished = float(loss(ls.x[None])[0])
        if polished < best:
            x, best = ls.x, polished
    return FitResult(
        m.name, x, best, segments.count, segments.length, segments.duration,
        time.perf_counter() - started, int(de.nit), evaluated[0], at_bounds(m, x),
    )  # fmt: skip


BOUND_TOLERANCE = 0.01
"""Relative distance to a bound at which a fitted parameter is flagged."""

MIN_TRAVEL = 1.0
"""Least path length of the training segments, m."""

MIN_TURN = 0.5
"""Least total heading change of the training segments, rad."""


def at_bounds(
    model: KinematicModel,
    params: np.ndarray,
    bounds: Sequence[tuple[float, float]] | None = None,
) -> tuple[str, ...]:
    """Return the names of the parameters at or within 1 % of a search bound.

    The bounds are the model's, or ``bounds`` (one ``(low, high)`` per
    parameter, e.g. those a parameter file records).

    The distance is relative to the bound's magnitude, with 1 (m or unitless)
    as the least scale, so a bound at 0 flags values within 0.01.

    Examples
    --------
    >>> from terrain_odom.kinematics import get_model
    >>> at_bounds(get_model("roc"), np.array([0.94, 0.65, 1e-16]))
    ('beta_2',)
    """
    flagged = []
    limits = model.bounds if bounds is None else bounds
    for name, value, (lo, hi) in zip(model.param_names, params, limits, strict=True):
        if any(abs(value - b) <= BOUND_TOLERANCE * max(abs(b), 1.0) for b in (lo, hi)):
            flagged.append(name)
    return tuple(flagged)


def _turn(segments: SegmentSet, track_width: float | None) -> float:
    """Total heading change of the segments, rad: measured, else by the wheels (positions alone).

    Segments between GPS fixes with no heading rows measure no heading: the
    ideal differential drive with ``track_width`` judges how much the robot
    turned (``inf``, no judgement, without one).
    """
    yaw = np.concatenate([b.target[:, 2] for b in segments.blocks])
    if np.isfinite(yaw).any():
        return float(np.nansum(np.abs(yaw)))
    if track_width is None:
        return math.inf
    return float(
        sum(
            np.abs(((b.v_r - b.v_l) / track_width * b.dt).sum(axis=1)).sum()
            for b in segments.blocks
        )
    )


def _check_excitation(name: str, segments: SegmentSet, track_width: float | None = None) -> None:
    """Refuse training data without motion or turning (nothing to identify).

    Raises
    ------
    EstimationError
        The segments' poses or wheels travel less than :data:`MIN_TRAVEL`, or
        they turn less than :data:`MIN_TURN` in all (by their headings; by
        the wheels and ``track_width`` where no heading was measured).
    """
    wheels = float(sum((0.5 * np.abs(b.v_l + b.v_r) * b.dt).sum() for b in segments.blocks))
    for what, travel in (("poses", segments.length), ("wheels", wheels)):
        if travel < MIN_TRAVEL:
            raise EstimationError(
                f"the {what} of the training segments travel {travel:.2f} m in all: no motion "
                f"to fit {name} to"
            )
    turn = _turn(segments, track_width)
    if turn < MIN_TURN:
        raise EstimationError(
            f"the training segments turn {np.degrees(turn):.1f} deg in all: no turning to "
            f"identify {name} from; fit on a log with turns"
        )
