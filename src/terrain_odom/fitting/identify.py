"""Offline identification of constant kinematic models from logs with poses.

Baril et al. (CRV 2020, section IV) cut the training trajectory into ``N``
distinct segments of travelled distance ``h_t`` (here: consecutive windows of
:func:`~terrain_odom.evaluation.spatial_windows`, or of
:func:`~terrain_odom.evaluation.time_windows` for a time horizon, chained end
to start and never crossing a ``segment`` change), integrate the model over
each from the measured start pose and minimise the sum of squared Mahalanobis
distances of the end-pose errors (their eq. 13; Martinez et al. 2004 eq. 14 is
the same loss):

.. math::

    l(\\mathbf{k}) = \\sum_{i=1}^N e_i^T \\Sigma^{-1} e_i,\\quad
    e_i = \\ominus(\\hat{x}_i) - \\ominus(x_i)

with the errors ``e_i = (dx, dy, wrap(dyaw))`` expressed in each segment's
start frame (for ``Sigma = I`` this equals the world-frame distance).

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

import dataclasses
import math
import re
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import differential_evolution, least_squares

from terrain_odom.evaluation.windows import (
    Windows,
    non_overlapping,
    padded_steps,
    spatial_windows,
    time_windows,
)
from terrain_odom.kinematics.integration import integrate, relative_pose, wrap_angle
from terrain_odom.kinematics.models import KinematicModel, get_model
from terrain_odom.records import WheelLog, change_runs

__all__ = [
    "DEFAULT_TRAINING_HORIZON",
    "Horizon",
    "FitOptions",
    "FitResult",
    "SegmentSet",
    "parse_horizon",
    "training_windows",
    "segment_set",
    "fit_model",
]

_INVALID_LOSS = 1e12  # loss of parameter sets whose twist is not finite (e.g. ROC with y_0 <= 0)
_BUCKET_ELEMENTS = 1 << 15  # max segments x steps per padded block


@dataclass(frozen=True)
class Horizon:
    """Segment length: a travelled distance (``unit == "m"``) or a duration (``"s"``)."""

    value: float
    unit: str = "m"

    def __post_init__(self) -> None:
        if self.unit not in ("m", "s"):
            raise ValueError(f"horizon unit must be 'm' or 's', got {self.unit!r}")
        if not (math.isfinite(self.value) and self.value > 0.0):
            raise ValueError(f"horizon must be a positive number, got {self.value}")

    def __str__(self) -> str:
        return f"{self.value:g}{self.unit}"

    def windows(self, log: WheelLog) -> Windows:
        """All windows of this horizon in ``log`` (overlapping, one per pose row)."""
        if self.unit == "m":
            return spatial_windows(log, self.value)
        return time_windows(log, self.value)


DEFAULT_TRAINING_HORIZON = Horizon(2.0, "m")  # Baril et al.'s h_t


def parse_horizon(text: str | float) -> Horizon:
    """Parse ``"2m"``, ``"1.5 s"`` or a bare number of metres.

    Raises
    ------
    ValueError
        Naming the text and the expected form.

    Examples
    --------
    >>> parse_horizon("2m"), parse_horizon("1.5 s"), parse_horizon(3)
    (Horizon(value=2.0, unit='m'), Horizon(value=1.5, unit='s'), Horizon(value=3.0, unit='m'))
    """
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        return Horizon(float(text), "m")
    match = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*([ms]?)\s*", str(text))
    if match is None or float(match.group(1)) <= 0.0:
        raise ValueError(
            f"horizon {text!r} is not a positive distance or duration like '2m' or '2s'"
        )
    return Horizon(float(match.group(1)), match.group(2) or "m")


def training_windows(log: WheelLog, horizon: Horizon, terrain: str | None = None) -> Windows:
    """Distinct training segments of a log: chained windows of ``horizon``.

    Parameters
    ----------
    log : WheelLog
        Log with pose measurements.
    horizon : Horizon
        Segment length ``h_t`` (m) or duration (s).
    terrain : str, optional
        Keep only segments that lie entirely on this terrain label (needs a
        terrain column); segments never cross a terrain change then.

    Returns
    -------
    Windows
        Non-overlapping windows, each inside one ``segment`` of the log.
    """
    if terrain is None:
        return non_overlapping(horizon.windows(log))
    if log.terrain is None:
        raise ValueError(f"{log.source}: no terrain column, cannot select terrain {terrain!r}")
    labels = np.asarray(log.terrain)
    # split the log at terrain changes as well as at segment changes
    split = dataclasses.replace(log, segment=change_runs(log.segment, labels))
    w = non_overlapping(horizon.windows(split))
    keep = labels[w.start] == terrain
    return Windows(start=w.start[keep], end=w.end[keep], length=w.length[keep])


@dataclass(frozen=True)
class _Block:
    """Padded speeds and durations of segments of similar length, shape (W, K)."""

    v_l: np.ndarray
    v_r: np.ndarray
    dt: np.ndarray
    target: np.ndarray  # (W, 3) measured end pose in the segment's start frame


@dataclass(frozen=True)
class SegmentSet:
    """Training segments of one or more logs, padded for vectorised integration.

    Attributes
    ----------
    blocks : tuple
        Segments grouped by length (padding < 2x, bounded memory).
    count : int
        Number of segments ``N``.
    length : float
        Total measured path length of the segments, m.
    duration : float
        Total duration of the segments, s.
    """

    blocks: tuple[_Block, ...]
    count: int
    length: float
    duration: float


def segment_set(logs: Sequence[WheelLog], windows: Sequence[Windows]) -> SegmentSet:
    """Pad the training segments of some logs once, for all loss evaluations.

    Parameters
    ----------
    logs : sequence of WheelLog
        The training logs.
    windows : sequence of Windows
        Their segments (e.g. from :func:`training_windows`), one per log.

    Returns
    -------
    SegmentSet
    """
    blocks: list[_Block] = []
    for full_log, full_win in zip(logs, windows, strict=True):
        log, win = _merge_constant_steps(full_log, full_win)
        n_steps = win.end - win.start
        if n_steps.size == 0:
            continue
        bucket = np.ceil(np.log2(n_steps)).astype(int)
        for b in np.unique(bucket):
            idx = np.flatnonzero(bucket == b)
            per_block = max(1, _BUCKET_ELEMENTS >> int(b))
            for i in range(0, idx.size, per_block):
                part = idx[i : i + per_block]
                rows, valid, dt = padded_steps(log, win, part)
                blocks.append(
                    _Block(
                        v_l=np.where(valid, log.v_l[rows], 0.0),
                        v_r=np.where(valid, log.v_r[rows], 0.0),
                        dt=dt,
                        target=relative_pose(log.pose[win.start[part]], log.pose[win.end[part]]),
                    )
                )
    count = sum(b.target.shape[0] for b in blocks)
    length = float(sum(w.length.sum() for w in windows))
    duration = float(sum(b.dt.sum() for b in blocks))
    return SegmentSet(tuple(blocks), count, length, duration)


def _merge_constant_steps(log: WheelLog, windows: Windows) -> tuple[WheelLog, Windows]:
    """Merge consecutive steps with equal track speeds inside each window.

    Every model's twist depends on the current speeds only, and a constant
    twist integrates exactly over the merged duration, so the predicted end
    poses are unchanged; the logs hold each wheel reading for ~5 rows, so this
    divides the integration work accordingly. Keeps the window start and end
    rows and every row where the speeds change inside a window.
    """
    n = len(log)
    inside = np.zeros(n + 1, dtype=int)
    np.add.at(inside, windows.start, 1)
    np.add.at(inside, windows.end, -1)
    in_window = np.cumsum(inside)[:n] > 0
    changed = np.r_[True, (log.v_l[1:] != log.v_l[:-1]) | (log.v_r[1:] != log.v_r[:-1])]
    keep = in_window & changed
    keep[windows.start] = True
    keep[windows.end] = True
    rows = np.flatnonzero(keep)
    merged = WheelLog(
        log.t[rows], log.v_l[rows], log.v_r[rows], log.pose[rows], None, log.segment[rows],
        log.source,
    )  # fmt: skip
    where = np.searchsorted(rows, [windows.start, windows.end])
    return merged, Windows(start=where[0], end=where[1], length=windows.length)


def _whitener(sigma: ArrayLike | None) -> np.ndarray:
    """Matrix ``L`` with ``L @ L.T = inv(Sigma)`` (identity for ``None``), shape (3, 3)."""
    if sigma is None:
        return np.eye(3)
    s = np.asarray(sigma, dtype=float)
    if s.shape == (3,):
        if not np.all(s > 0.0):
            raise ValueError(f"sigma standard deviations must be > 0, got {s.tolist()}")
        return np.diag(1.0 / s)
    if s.shape != (3, 3) or not np.allclose(s, s.T):
        raise ValueError(f"Sigma must be 3 standard deviations or a symmetric 3x3, got {s}")
    try:
        return np.linalg.cholesky(np.linalg.inv(s))
    except np.linalg.LinAlgError:
        raise ValueError(f"Sigma must be positive definite, got {s.tolist()}") from None


def residuals(
    model: KinematicModel,
    params: ArrayLike,
    segments: SegmentSet,
    *,
    whitener: np.ndarray | None = None,
    track_width: float | None = None,
) -> np.ndarray:
    """Whitened end-of-segment pose errors of one or many parameter sets.

    Parameters
    ----------
    model : KinematicModel
        The model.
    params : array_like, shape (S, k)
        ``S`` parameter sets (a DE population) in ``model.param_names`` order.
    segments : SegmentSet
        Training segments.
    whitener : ndarray, shape (3, 3), optional
        ``L`` with ``L L^T = Sigma^-1``; identity if omitted.
    track_width : float, optional
        Nominal ``B``, m, for models that need it.

    Returns
    -------
    ndarray, shape (S, N, 3)
        ``L^T e`` per segment, so that the loss is the sum of squares.
    """
    p = np.asarray(params, dtype=float)[:, None, :]  # (S, 1, k): broadcasts over (W, K)
    out = []
    for block in segments.blocks:
        v_x, v_y, omega = model.twist(block.v_l, block.v_r, p, track_width)
        shape = (p.shape[0], *block.dt.shape)  # (S, W, K), also for idd (no parameter)
        v_x, v_y, omega, dt = (np.broadcast_to(c, shape) for c in (v_x, v_y, omega, block.dt))
        end = integrate(v_x, v_y, omega, dt)[..., -1, :]
        err = end - block.target
        err[..., 2] = wrap_angle(err[..., 2])
        out.append(err)
    err = np.concatenate(out, axis=1)
    return err if whitener is None else err @ whitener


def _loss(res: np.ndarray) -> np.ndarray:
    """Sum of squares per parameter set; non-finite sets get a large finite loss."""
    loss = np.sum(res * res, axis=(-2, -1))
    return np.where(np.isfinite(loss), loss, _INVALID_LOSS)


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
        Differential-evolution generations and parameter sets evaluated.
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
    whitener = _whitener(opt.sigma)

    def loss(pop: np.ndarray) -> np.ndarray:
        return _loss(residuals(m, pop, segments, whitener=whitener, track_width=track_width))

    k = len(m.param_names)
    if k == 0:
        x = np.zeros(0)
        return FitResult(
            m.name, x, float(loss(x[None])[0]), segments.count, segments.length,
            segments.duration, time.perf_counter() - started, 0, 1,
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
    x, best, nfev = np.asarray(de.x, dtype=float), float(de.fun), int(de.nfev)
    if opt.polish:
        lo, hi = np.array(m.bounds, dtype=float).T

        def flat(q: np.ndarray) -> np.ndarray:
            res = residuals(m, q[None], segments, whitener=whitener, track_width=track_width)
            return np.nan_to_num(res.ravel(), nan=1e6, posinf=1e6, neginf=-1e6)

        ls = least_squares(
            flat,
            np.clip(x, lo, hi),
            bounds=(lo, hi),
            x_scale="jac",
        )
        nfev += int(ls.nfev)
        polished = float(loss(ls.x[None])[0])
        if polished < best:
            x, best = ls.x, polished
    return FitResult(
        m.name, x, best, segments.count, segments.length, segments.duration,
        time.perf_counter() - started, int(de.nit), nfev,
    )  # fmt: skip
