"""Odometry error metrics: model error over spatial windows, dead reckoning, settling.

Spatial-window error (Baril et al., CRV 2020, section IV), on the windows of
:mod:`terrain_odom.evaluation.windows`. The kinematic model is integrated
from the *measured* start pose over the wheel rows ``start .. end - 1`` (row ``k`` held for
``t[k+1] - t[k]``, zero-order hold) and compared with the measured end pose:

- translational error per metre = ``|p_pred - p_meas| / length`` (m/m),
- angular error per metre = ``|wrap(yaw_pred - yaw_meas)| / length`` (deg/m).

For a model integrated from the measured start pose the translational error
before division equals evo's RPE ``translation_part`` on the same index pairs
(``|t(Q_rel^-1 P_rel)|`` with ``P_rel`` the model's relative motion).

The twist comes from a callable ``twist_fn(v_l, v_r, window_index)``, so the
same code serves constant models and estimators whose parameters change
per window (each window uses only the estimate available at its start).

The absolute trajectory error is :mod:`terrain_odom.evaluation.ate`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from terrain_odom.evaluation.windows import Windows, padded_steps
from terrain_odom.kinematics.integration import integrate, wrap_angle
from terrain_odom.kinematics.models import KinematicModel, twist_icr
from terrain_odom.records import WheelLog

__all__ = [
    "TwistFn",
    "WindowErrors",
    "ErrorStats",
    "ErrorSummary",
    "model_twist",
    "icr_twist_from_rows",
    "icr_twist_per_window",
    "window_poses",
    "predict_window_ends",
    "error_stats",
    "window_errors",
    "summarize",
    "dead_reckon",
    "settling_time",
]

Twist = tuple[np.ndarray, np.ndarray, np.ndarray]
TwistFn = Callable[[np.ndarray, np.ndarray, np.ndarray], Twist]
"""``twist_fn(v_l, v_r, window_index) -> (v_x, v_y, omega)``.

``v_l, v_r`` have shape ``(W, K)`` (track speeds, m/s, one row per window),
``window_index`` has shape ``(W,)`` (indices into the
:class:`~terrain_odom.evaluation.windows.Windows`, so per-window parameters are ``params[window_index][:, None]``); the returned
twist (m/s, m/s, rad/s) must broadcast to ``(W, K)``.
"""

_CHUNK_ELEMENTS = 1 << 16  # max W * K integrated at once (bounds memory)


@dataclass(frozen=True)
class WindowErrors:
    """Prediction errors of a model over the windows of a log.

    Attributes
    ----------
    windows : Windows
        The evaluated windows (``W`` of them).
    predicted : ndarray, shape (W, 3)
        Predicted end pose ``x, y, yaw`` (m, m, rad).
    translation : ndarray, shape (W,)
        Distance between predicted and measured end position, m.
    rotation : ndarray, shape (W,)
        Absolute wrapped yaw difference at the end, rad.
    """

    windows: Windows
    predicted: np.ndarray
    translation: np.ndarray
    rotation: np.ndarray

    @property
    def translation_per_m(self) -> np.ndarray:
        """Translational error per metre travelled, shape (W,), m/m."""
        return self.translation / self.windows.length

    @property
    def rotation_per_m(self) -> np.ndarray:
        """Angular error per metre travelled, shape (W,), deg/m."""
        return np.degrees(self.rotation) / self.windows.length


@dataclass(frozen=True)
class ErrorStats:
    """Distribution summary of one error (NaN statistics when ``count == 0``)."""

    median: float
    q25: float
    q75: float
    mean: float
    count: int

    def to_dict(self) -> dict[str, float | int | None]:
        """JSON-ready dict; NaN becomes ``None``."""
        return {
            "median": _json_float(self.median),
            "q25": _json_float(self.q25),
            "q75": _json_float(self.q75),
            "mean": _json_float(self.mean),
            "count": self.count,
        }


@dataclass(frozen=True)
class ErrorSummary:
    """Summary of window errors.

    Attributes
    ----------
    translation : ErrorStats
        Translational error per metre, m/m.
    rotation : ErrorStats
        Angular error per metre, deg/m.
    """

    translation: ErrorStats
    rotation: ErrorStats

    def to_dict(self) -> dict[str, dict[str, float | int | None]]:
        """JSON-ready dict keyed ``translation_m_per_m`` and ``rotation_deg_per_m``."""
        return {
            "translation_m_per_m": self.translation.to_dict(),
            "rotation_deg_per_m": self.rotation.to_dict(),
        }


def _json_float(value: float) -> float | None:
    return None if math.isnan(value) else float(value)


def _chunks(n_steps: np.ndarray) -> list[np.ndarray]:
    """Group window indices so that padding stays < 2x and memory is bounded.

    Windows are bucketed by ``ceil(log2(n_steps))``; each bucket is split so
    that ``len(chunk) * 2**bucket <= _CHUNK_ELEMENTS`` (at least one window).
    """
    bucket = np.ceil(np.log2(np.maximum(n_steps, 1))).astype(int)  # a 0-step window: 1
    chunks: list[np.ndarray] = []
    for b in np.unique(bucket):
        idx = np.flatnonzero(bucket == b)
        per_chunk = max(1, _CHUNK_ELEMENTS >> int(b))
        chunks.extend(idx[i : i + per_chunk] for i in range(0, idx.size, per_chunk))
    return chunks


def window_poses(
    log: WheelLog, windows: Windows, twist_fn: TwistFn, start: np.ndarray | None = None
) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """Integrate the model over every window, a chunk of windows at a time.

    Windows are integrated together as ``(W, K)`` arrays padded with
    ``dt = 0`` and a zero twist (in a few memory-bounded chunks of similar
    ``K``); ``twist_fn`` sees the padding too, filled with real log speeds.

    Parameters
    ----------
    log : WheelLog
        The log the windows belong to.
    windows : Windows
        The windows (``W`` of them).
    twist_fn : TwistFn
        ``twist_fn(v_l, v_r, window_index) -> (v_x, v_y, omega)``.
    start : ndarray, shape (W, 3), optional
        Start pose of each window; the measured pose of its start row if omitted.

    Yields
    ------
    idx : ndarray of int, shape (C,)
        The windows of the chunk.
    rows, valid : ndarray, shape (C, K)
        Log row of each step and False on padding (:func:`padded_steps`).
    poses : ndarray, shape (C, K + 1, 3)
        Pose at each step's row and after the last step (padding repeats the
        end pose), m, m, rad.
    """
    first = log.pose[windows.start] if start is None else np.asarray(start, dtype=float)
    for idx in _chunks(windows.end - windows.start):
        rows, valid, dt = padded_steps(log, windows, idx)
        twist = twist_fn(log.v_l[rows], log.v_r[rows], idx)
        v_x, v_y, omega = (np.where(valid, np.broadcast_to(c, rows.shape), 0.0) for c in twist)
        yield idx, rows, valid, integrate(v_x, v_y, omega, dt, start=first[idx])


def predict_window_ends(
    log: WheelLog, windows: Windows, twist_fn: TwistFn, start: np.ndarray | None = None
) -> np.ndarray:
    """Integrate the model over every window from its start pose (:func:`window_poses`).

    Parameters
    ----------
    log : WheelLog
        The log the windows belong to.
    windows : Windows
        Windows from :func:`~terrain_odom.evaluation.windows.spatial_windows`.
    twist_fn : TwistFn
        ``twist_fn(v_l, v_r, window_index) -> (v_x, v_y, omega)``.
    start : ndarray, shape (W, 3), optional
        Start pose of each window; the measured pose of its start row if omitted.

    Returns
    -------
    ndarray, shape (W, 3)
        Predicted pose ``x, y, yaw`` (m, m, rad) at each window's end row.
    """
    predicted = np.empty((len(windows), 3))
    for idx, _, _, poses in window_poses(log, windows, twist_fn, start):
        predicted[idx] = poses[:, -1]
    return predicted


def window_errors(log: WheelLog, windows: Windows, twist_fn: TwistFn) -> WindowErrors:
    """Errors of a model's predicted end poses over spatial windows.

    Parameters
    ----------
    log : WheelLog
        The log the windows belong to.
    windows : Windows
        Windows from :func:`~terrain_odom.evaluation.windows.spatial_windows`.
    twist_fn : TwistFn
        ``twist_fn(v_l, v_r, window_index) -> (v_x, v_y, omega)``; see
        :func:`model_twist` and :func:`icr_twist_from_rows`.

    Returns
    -------
    WindowErrors
        Per-window absolute errors (m, rad); ``translation_per_m`` and
        ``rotation_per_m`` give them per metre.

    Examples
    --------
    Straight line at 1 m/s, measured exactly, a model 10 % too fast:

    >>> from terrain_odom.evaluation.windows import spatial_windows
    >>> from terrain_odom.kinematics.models import get_model
    >>> n = 6
    >>> pose = np.c_[np.arange(n, dtype=float), np.zeros(n), np.zeros(n)]
    >>> log = WheelLog(np.arange(n, dtype=float), np.ones(n), np.ones(n), pose,
    ...                None, np.zeros(n, dtype=int))
    >>> fast = model_twist(get_model("edd-sym"), [1.1, 1.0])
    >>> err = window_errors(log, spatial_windows(log), fast)
    >>> err.translation_per_m.round(12).tolist()
    [0.1, 0.1, 0.1, 0.1]
    """
    predicted = predict_window_ends(log, windows, twist_fn)
    measured = log.pose[windows.end]
    return WindowErrors(
        windows=windows,
        predicted=predicted,
        translation=np.linalg.norm(predicted[:, :2] - measured[:, :2], axis=1),
        rotation=np.abs(wrap_angle(predicted[:, 2] - measured[:, 2])),
    )


def error_stats(values: np.ndarray) -> ErrorStats:
    """Median, quartiles, mean and count of some errors; NaN (not measured) left out.

    Examples
    --------
    >>> error_stats(np.array([1.0, np.nan, 3.0])).median, error_stats(np.zeros(0)).count
    (2.0, 0)
    """
    values = values[~np.isnan(values)]
    if values.size == 0:
        return ErrorStats(math.nan, math.nan, math.nan, math.nan, 0)
    q25, median, q75 = np.percentile(values, [25.0, 50.0, 75.0])
    return ErrorStats(float(median), float(q25), float(q75), float(values.mean()), values.size)


def summarize(errors: WindowErrors | Sequence[WindowErrors]) -> ErrorSummary:
    """Median, quartiles, mean and count of the per-metre window errors.

    Parameters
    ----------
    errors : WindowErrors or sequence of WindowErrors
        Errors of one log, or of several logs pooled together.

    Returns
    -------
    ErrorSummary
        ``translation`` in m/m and ``rotation`` in deg/m.
    """
    parts = [errors] if isinstance(errors, WindowErrors) else list(errors)
    none = np.zeros(0)
    return ErrorSummary(
        translation=error_stats(np.concatenate([none, *(e.translation_per_m for e in parts)])),
        rotation=error_stats(np.concatenate([none, *(e.rotation_per_m for e in parts)])),
    )


def model_twist(
    model: KinematicModel, params: ArrayLike, track_width: float | None = None
) -> TwistFn:
    """Twist callable of a kinematic model with constant or per-window parameters.

    Parameters
    ----------
    model : KinematicModel
        The model, e.g. ``get_model("idd")``.
    params : array_like, shape (P,) or (W, P)
        Parameters in ``model.param_names`` order; one row per window for
        per-window parameters.
    track_width : float, optional
        Nominal track width ``B``, m, for models with ``needs_track_width``.

    Returns
    -------
    TwistFn
        ``twist_fn(v_l, v_r, window_index)``.
    """
    p = np.asarray(params, dtype=float)
    if p.ndim not in (1, 2) or p.shape[-1] != len(model.param_names):
        raise ValueError(
            f"model {model.name!r} takes parameters {model.param_names} as shape (P,) or "
            f"(W, P) with P = {len(model.param_names)}, got shape {p.shape}"
        )
    if model.needs_track_width and track_width is None:
        raise ValueError(f"model {model.name!r} needs the nominal track_width")

    def twist_fn(v_l: np.ndarray, v_r: np.ndarray, window_index: np.ndarray) -> Twist:
        return model.twist(v_l, v_r, p if p.ndim == 1 else p[window_index], track_width)

    return twist_fn


def icr_twist_from_rows(
    windows: Windows,
    y_l: ArrayLike,
    y_r: ArrayLike,
    x_icr: ArrayLike,
    alpha: ArrayLike = 1.0,
) -> TwistFn:
    """Twist callable of the ICR model with parameters given per log row.

    Each window uses the parameters of its start row only (the estimate
    available when the window starts); other rows are never read.

    Parameters
    ----------
    windows : Windows
        The windows the callable will be evaluated on.
    y_l, y_r, x_icr : array_like, shape (N,)
        ICR coordinates per log row, m (see :func:`~terrain_odom.kinematics.twist_icr`).
    alpha : array_like, shape (N,) or scalar, optional
        Longitudinal slip factor per log row.

    Returns
    -------
    TwistFn
        ``twist_fn(v_l, v_r, window_index)``.
    """
    rows = windows.start
    return icr_twist_per_window(
        *(
            np.broadcast_to(np.asarray(a, dtype=float), np.shape(y_l))[rows]
            for a in (y_l, y_r, x_icr, alpha)
        )
    )


def icr_twist_per_window(
    y_l: ArrayLike, y_r: ArrayLike, x_icr: ArrayLike, alpha: ArrayLike = 1.0
) -> TwistFn:
    """Twist callable of the ICR model with one parameter set per window.

    Parameters
    ----------
    y_l, y_r, x_icr : array_like, shape (W,)
        ICR coordinates of each window, m (see :func:`~terrain_odom.kinematics.twist_icr`).
    alpha : array_like, shape (W,) or scalar, optional
        Longitudinal slip factor of each window.

    Returns
    -------
    TwistFn
        ``twist_fn(v_l, v_r, window_index)``.
    """
    shape = np.shape(y_l)
    per_window = [
        np.broadcast_to(np.asarray(a, dtype=float), shape) for a in (y_l, y_r, x_icr, alpha)
    ]

    def twist_fn(v_l: np.ndarray, v_r: np.ndarray, window_index: np.ndarray) -> Twist:
        return twist_icr(v_l, v_r, *(a[window_index][:, None] for a in per_window))

    return twist_fn


def dead_reckon(log: WheelLog, v_x: ArrayLike, v_y: ArrayLike, omega: ArrayLike) -> np.ndarray:
    """Integrate per-row twists over each segment from its first measured pose.

    Row ``k``'s twist is held from ``t[k]`` to ``t[k+1]``. Nothing is
    integrated across a segment change; rows before a segment's first full
    pose measurement (and whole segments without one) are NaN.

    Parameters
    ----------
    log : WheelLog
        Times, segments and pose measurements.
    v_x, v_y, omega : array_like, shape (N,)
        Body twist of each row (m/s, m/s, rad/s).

    Returns
    -------
    ndarray, shape (N, 3)
        Dead-reckoned ``x, y, yaw``.
    """
    v_x, v_y, omega = (np.asarray(a, dtype=float) for a in (v_x, v_y, omega))
    out = np.full((len(log), 3), np.nan)
    has_pose = log.has_pose
    for run in log.run_ranges():
        first, stop = run.start, run.stop
        rows = np.flatnonzero(has_pose[first:stop])
        if rows.size == 0:
            continue
        k0 = first + int(rows[0])
        steps = slice(k0, stop - 1)
        dt = np.diff(log.t[k0:stop])
        out[k0:stop] = integrate(v_x[steps], v_y[steps], omega[steps], dt, start=log.pose[k0])
    return out


def settling_time(
    t: ArrayLike,
    values: ArrayLike,
    final: ArrayLike,
    tolerance: ArrayLike,
    *,
    t_from: float,
) -> float:
    """Time after ``t_from`` until ``values`` stay within ``tolerance`` of ``final``.

    Parameters
    ----------
    t : array_like, shape (N,)
        Times, s.
    values : array_like, shape (N, P)
        Estimates over time (e.g. ``y_l, y_r, x_icr, alpha``).
    final : array_like, shape (P,)
        Values to settle to.
    tolerance : array_like, shape (P,)
        Allowed absolute deviation per component.
    t_from : float
        Start of the clock (e.g. the terrain change, or the first motion after it), s.

    Returns
    -------
    float
        Seconds from ``t_from`` to the first time after which every component
        stays inside its band until the end; ``inf`` if it is outside at the
        last sample, 0 if it never leaves the band after ``t_from``.

    Examples
    --------
    >>> t = np.arange(6.0)
    >>> v = np.array([[0.0], [0.5], [0.95], [1.2], [1.05], [1.0]])
    >>> settling_time(t, v, [1.0], [0.1], t_from=1.0)
    3.0
    """
    t = np.asarray(t, dtype=float)
    v = np.asarray(values, dtype=float).reshape(t.size, -1)
    outside = np.any(np.abs(v - np.asarray(final, dtype=float)) > np.asarray(tolerance), axis=1)
    outside &= t >= t_from
    rows = np.flatnonzero(outside)
    if rows.size == 0:
        return 0.0
    if rows[-1] == t.size - 1:
        return float("inf")
    return float(t[rows[-1] + 1] - t_from)
