"""Temporal calibration of pose stamps against wheel speeds (the pose delay).

A pose delay ``d`` (s) means that a pose stamped ``t`` in the log was measured
at wheel time ``t - d``: e.g. an ICP pose stamped when the scan was matched,
not when it was taken, or wheel speeds logged as the latest value received.
If ``d`` is ignored, every window of wheel speeds that predicts a pose change
integrates the wrong stretch of time, which looks like slip to any estimator.

:func:`estimate_pose_delay` finds ``d`` offline from the whole log, in the
manner of the time-offset estimation of Kalibr (Furgale et al. 2013): the
measured heading changes over short intervals are compared with the
integral of the ideal differential-drive yaw rate ``(v_r - v_l) / B`` over
the same intervals moved ``d`` earlier, times a fitted scale (skid-steer
robots turn less than the ideal model); the ``d`` of least squared residual
over a grid, refined by a parabola, is the estimate. Only the heading is
used, so a heading-only log can be calibrated, and the estimate does not
depend on how well any slip model fits the positions.

:func:`delay_wheel_speeds` applies ``d``. The log keeps its rows and its
time stamps (the pose clock): each row's wheel speeds are replaced by the
mean of the recorded speeds over ``[t_k - d, t_(k+1) - d]`` (the last row of
a segment by the speed recorded at ``t_k - d``), within the row's segment,
holding the first and last speeds beyond its ends. The wheel rows and pose
rows therefore stay one row each, the run's outputs keep the log's stamps,
and the travelled distance and no-slip heading change between any two rows
are those the recorded speeds give over the delayed interval, exactly.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from terrain_odom.errors import EstimationError
from terrain_odom.kinematics import wrap_angle
from terrain_odom.records import WheelLog

__all__ = [
    "PoseDelayEstimate",
    "TimeCalibration",
    "estimate_pose_delay",
    "delay_wheel_speeds",
    "delay_sensors",
    "calibrate_pose_delay",
    "shows_pose_delay",
]

MIN_PAIRS = 20
"""Fewest heading changes an estimate is made from."""
MAX_STARTS = 10000
"""Most heading changes per run (beyond it, every k-th heading starts one)."""


@dataclass(frozen=True)
class PoseDelayEstimate:
    """Estimated delay of the pose stamps behind the wheel speeds.

    Attributes
    ----------
    delay : float
        ``d``, s: a pose stamped ``t`` was measured at wheel time ``t - d``.
    std : float
        Approximate standard error of ``delay``, s (from the curvature of the
        cost at its minimum, taking the heading changes as independent).
    yaw_rate_scale : float
        Fitted ratio of the measured turn rate to the ideal differential
        drive's ``(v_r - v_l) / B`` (< 1 on a skid-steer robot).
    pairs : int
        Number of heading changes used.
    """

    delay: float
    std: float
    yaw_rate_scale: float
    pairs: int


def estimate_pose_delay(
    log: WheelLog,
    track_width: float,
    *,
    max_delay: float = 1.0,
    step: float = 0.01,
    span: float = 0.5,
    max_span: float = 2.0,
    max_std: float = 0.05,
) -> PoseDelayEstimate:
    """Estimate the pose delay ``d`` of a log from its heading changes (see the module).

    Parameters
    ----------
    log : WheelLog
        Wheel speeds with yaw measurements (positions are not needed); the
        heading changes never cross a ``segment`` change.
    track_width : float
        Nominal track width ``B``, m (only scales the fitted yaw-rate scale).
    max_delay : float
        The search range is ``[-max_delay, max_delay]``, s.
    step : float
        Grid step of the search, s (the minimum is then refined by a parabola).
    span : float
        Each heading change runs from a yaw measurement to the first one at
        least ``span`` s later, s.
    max_span : float
        Heading changes longer than this (gaps in the poses) are left out, s.
    max_std : float
        Largest acceptable standard error of the estimate, s.

    Returns
    -------
    PoseDelayEstimate

    Raises
    ------
    EstimationError
        Fewer than :data:`MIN_PAIRS` usable heading changes, a minimum at the
        edge of the search range, or a standard error above ``max_std``
        (too little turning, or turning too steady, to time it).
    """
    if not (track_width > 0.0 and 0.0 < step < max_delay and 0.0 < span <= max_span):
        raise ValueError(
            f"need track_width > 0, 0 < step < max_delay, 0 < span <= max_span; got "
            f"{track_width}, {step}, {max_delay}, {span}, {max_span}"
        )
    lags = np.arange(-max_delay, max_delay + 0.5 * step, step)
    measured, turned = _heading_changes(log, lags, span, max_span)
    if measured.size < MIN_PAIRS:
        raise EstimationError(
            f"{log.source}: only {measured.size} heading changes over {span:g}-{max_span:g} s "
            f"(at least {MIN_PAIRS} are needed) to estimate the pose delay"
        )
    energy = np.einsum("ij,ij->i", turned, turned)
    scale = (turned @ measured) / np.maximum(energy, np.finfo(float).tiny)
    cost = np.mean((measured - scale[:, None] * turned) ** 2, axis=1)
    i = int(np.argmin(cost))
    if i in (0, lags.size - 1):
        raise EstimationError(
            f"{log.source}: the best pose delay lies at the edge of the search range "
            f"+-{max_delay:g} s; the heading does not follow the wheel yaw rate (too little "
            "turning?) - give the delay explicitly"
        )
    c_minus, c_0, c_plus = cost[i - 1 : i + 2]
    curvature = (c_minus - 2.0 * c_0 + c_plus) / step**2  # d2 cost / d lag2, rad^2/s^2
    offset = 0.5 * step * (c_minus - c_plus) / (c_minus - 2.0 * c_0 + c_plus)
    std = float(np.sqrt(2.0 * c_0 / (measured.size * curvature)))
    if not std <= max_std:
        raise EstimationError(
            f"{log.source}: too little turning to estimate the pose delay (standard error "
            f"{std:.3f} s > {max_std:g} s at {lags[i]:+.2f} s); give the delay explicitly"
        )
    return PoseDelayEstimate(
        float(lags[i] + offset), std, float(scale[i]) * track_width, measured.size
    )


def _heading_changes(
    log: WheelLog, lags: np.ndarray, span: float, max_span: float
) -> tuple[np.ndarray, np.ndarray]:
    """Measured heading changes (rad) and the no-slip turn over them at every lag.

    Returns ``measured`` of shape (P,) and ``turned`` of shape (L, P): the
    integral of ``v_r - v_l`` (m; divide by ``B`` for rad) over each interval
    moved ``lags`` earlier. Only intervals whose moved copies stay inside
    their segment for every lag are kept, so every lag is scored on the same
    heading changes.
    """
    measured, turned = [np.zeros(0)], [np.zeros((lags.size, 0))]
    for rows in _segment_rows(log):
        t = log.t[rows]
        speeds = np.c_[log.v_r[rows] - log.v_l[rows]]
        yaw_rows = np.flatnonzero(np.isfinite(log.pose[rows, 2]))
        # a long log at a high rate: every k-th start (overlapping changes add cost, not
        # information); logs of up to MAX_STARTS headings keep every start
        starts = yaw_rows[:: max(1, -(-yaw_rows.size // MAX_STARTS))]
        end = np.searchsorted(t[yaw_rows], t[starts] + span)
        a, b = starts[end < yaw_rows.size], yaw_rows[end[end < yaw_rows.size]]
        keep = (
            (t[b] - t[a] <= max_span) & (t[a] - lags.max() >= t[0]) & (t[b] - lags.min() <= t[-1])
        )
        a, b = a[keep], b[keep]
        yaw = log.pose[rows, 2]
        measured.append(wrap_angle(yaw[b] - yaw[a]))
        late = _integral(t, speeds, t[b][None, :] - lags[:, None])
        early = _integral(t, speeds, t[a][None, :] - lags[:, None])
        turned.append((late - early)[..., 0])
    return np.concatenate(measured), np.concatenate(turned, axis=1)


def _segment_rows(log: WheelLog) -> list[np.ndarray]:
    """Row indices of each run of at least two rows (``WheelLog.run_ranges``), in order."""
    return [np.arange(run.start, run.stop) for run in log.run_ranges() if len(run) > 1]


def _integral(t: np.ndarray, values: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Integral from ``t[0]`` to ``s`` of zero-order-held ``values`` (shape (N, C)).

    Beyond the ends, the first and last values are held. Returns shape
    ``s.shape + (C,)``.
    """
    steps = values[:-1] * np.diff(t)[:, None]
    cum = np.concatenate([np.zeros((1, values.shape[1])), np.cumsum(steps, axis=0)])
    i = np.clip(np.searchsorted(t, s, side="right") - 1, 0, t.size - 1)
    return cum[i] + values[i] * (s - t[i])[..., None]


def delay_wheel_speeds(log: WheelLog, delay: float) -> WheelLog:
    """Return the log with its wheel speeds delayed by ``delay`` s (see the module).

    Parameters
    ----------
    log : WheelLog
        The log as recorded.
    delay : float
        Pose delay ``d``, s: a pose stamped ``t`` was measured at wheel time
        ``t - d``. 0 returns ``log`` itself.

    Returns
    -------
    WheelLog
        Same rows, stamps, poses, terrain and segments; row ``k``'s speeds
        are the mean recorded speeds over ``[t_k - d, t_(k+1) - d]``.

    Examples
    --------
    >>> log = WheelLog(np.arange(4.0), np.array([0.0, 1.0, 2.0, 3.0]), np.zeros(4),
    ...                np.full((4, 3), np.nan), None, np.zeros(4, int))
    >>> delay_wheel_speeds(log, 0.5).v_l.tolist()
    [0.0, 0.5, 1.5, 2.0]
    """
    if delay == 0.0:
        return log
    speeds = np.c_[log.v_l, log.v_r]
    out = speeds.copy()  # single-row segments keep their speeds (nothing is integrated)
    for rows in _segment_rows(log):
        out[rows] = _held_means(log.t[rows], speeds[rows], log.t[rows] - delay)
    return WheelLog(log.t, out[:, 0], out[:, 1], log.pose, log.terrain, log.segment, log.source)


def _held_means(t: np.ndarray, speeds: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Mean of zero-order-held ``speeds`` (rows at ``t``) over ``[s_k, s_(k+1)]``; the last at ``s``."""
    shifted = _integral(t, speeds, s)
    out = np.empty((s.size, speeds.shape[1]))
    out[:-1] = np.diff(shifted, axis=0) / np.diff(s)[:, None]
    last = np.clip(np.searchsorted(t, s[-1], side="right") - 1, 0, t.size - 1)
    out[-1] = speeds[last]
    return out


def delay_sensors(log: WheelLog, position_delay: float, heading_delay: float) -> WheelLog:
    """Apply a position delay and a different heading delay to a log.

    A fix stamped ``t`` was measured at wheel time ``t - position_delay``, a
    heading stamped ``t`` at ``t - heading_delay``. The positions keep their
    stamps and the wheel speeds are delayed by ``position_delay``
    (:func:`delay_wheel_speeds`); each heading moves to the stamp
    ``t + position_delay - heading_delay`` of that clock, on a row of its own
    (or onto a row at that time without a heading), within its run
    (headings moved beyond a run's first or last row are dropped). Every
    row's speeds are then the recorded speeds' mean over its delayed
    interval, so travel and turn between any two rows stay exact.

    Parameters
    ----------
    log : WheelLog
        The log as recorded.
    position_delay, heading_delay : float
        s.

    Returns
    -------
    WheelLog
        ``delay_wheel_speeds(log, position_delay)`` when the delays are equal.
    """
    if heading_delay == position_delay:
        return delay_wheel_speeds(log, position_delay)
    shift = position_delay - heading_delay
    parts = [
        _moved_headings(log.take(np.asarray(rows)), shift, position_delay)
        for rows in log.run_ranges()
    ]
    t, v_l, v_r, pose, segment = (
        np.concatenate([getattr(p, name) for p in parts])
        for name in ("t", "v_l", "v_r", "pose", "segment")
    )
    labels = [p.terrain for p in parts if p.terrain is not None]
    terrain = np.concatenate(labels) if log.terrain is not None else None
    return WheelLog(t, v_l, v_r, pose, terrain, segment, log.source)


_SAME_STAMP = 1e-6
"""Stamps closer than this (s) are one row."""


def _moved_headings(run: WheelLog, shift: float, delay: float) -> WheelLog:
    """One run with its headings moved ``shift`` s later and its speeds delayed ``delay`` s."""
    yaw_rows = np.flatnonzero(run.has_yaw)
    moved_t = run.t[yaw_rows] + shift
    inside = (moved_t >= run.t[0]) & (moved_t <= run.t[-1])
    yaw_rows, moved_t = yaw_rows[inside], moved_t[inside]
    stay = np.flatnonzero(run.has_position | ~run.has_yaw)  # rows that keep their stamp
    pose = run.pose[stay].copy()
    pose[:, 2] = np.nan
    t = np.concatenate([run.t[stay], moved_t])
    pose = np.concatenate(
        [pose, np.column_stack([np.full((moved_t.size, 2), np.nan), run.pose[yaw_rows, 2]])]
    )
    order = np.argsort(t, kind="stable")
    t, pose = t[order], pose[order]
    new = np.r_[True, np.diff(t) > _SAME_STAMP]  # a heading landing on a row joins it
    group = np.cumsum(new) - 1
    merged = np.full((int(group[-1]) + 1 if t.size else 0, 3), np.nan)
    for col in range(3):
        ok = np.isfinite(pose[:, col])
        merged[group[ok][::-1], col] = pose[ok, col][::-1]  # the first finite value of a group
    t = t[new]
    source = np.clip(np.searchsorted(run.t, t + _SAME_STAMP, side="right") - 1, 0, len(run) - 1)
    speeds = (
        _held_means(run.t, np.c_[run.v_l, run.v_r], t - delay)
        if t.size > 1
        else np.c_[run.v_l[source], run.v_r[source]]
    )
    return WheelLog(
        t,
        speeds[:, 0],
        speeds[:, 1],
        merged,
        None if run.terrain is None else run.terrain[source],
        run.segment[source],
        run.source,
    )


@dataclass(frozen=True)
class TimeCalibration:
    """The pose delay applied to a log, and how it was obtained.

    Attributes
    ----------
    pose_delay : float
        ``d`` applied, s (to the positions where the headings have their own).
    estimate : PoseDelayEstimate or None
        The heading-based estimate when a delay was estimated from the
        headings (``auto``); None otherwise.
    heading_delay : float or None
        The headings' own delay, s; None: ``pose_delay``.
    position_std : float or None
        Standard error of ``pose_delay`` where it was estimated from the
        positions (:func:`~terrain_odom.evaluation.calibration.fit_sensors`), s.
    """

    pose_delay: float
    estimate: PoseDelayEstimate | None = None
    heading_delay: float | None = None
    position_std: float | None = None

    @property
    def heading_delay_applied(self) -> float:
        """The headings' delay, s (``pose_delay`` unless they have their own)."""
        return self.pose_delay if self.heading_delay is None else self.heading_delay

    def to_dict(self) -> dict[str, Any]:
        """Plain data for reports: ``pose_delay_s``, ``estimated`` and the estimate's figures.

        ``heading_delay_s`` too where the headings have a delay of their own.
        """
        out: dict[str, Any] = {
            "pose_delay_s": self.pose_delay,
            "estimated": self.estimate is not None or self.position_std is not None,
        }
        if self.heading_delay_applied != self.pose_delay:
            out["heading_delay_s"] = self.heading_delay_applied
        if self.estimate is not None:
            e = self.estimate
            out.update(std_s=e.std, yaw_rate_scale=e.yaw_rate_scale, heading_changes=e.pairs)
        if self.position_std is not None:  # pose_delay is the positions' own estimate
            out.update(std_s=self.position_std, from_positions=True)
        return out


def shows_pose_delay(timing: Mapping[str, Any]) -> bool:
    """Whether a :meth:`TimeCalibration.to_dict` is worth reporting: estimated, or not 0."""
    return bool(timing["estimated"]) or timing["pose_delay_s"] != 0.0


def calibrate_pose_delay(
    log: WheelLog, pose_delay: float | Literal["auto"], track_width: float
) -> tuple[WheelLog, TimeCalibration]:
    """Apply a configured pose delay (``time.pose_delay``) to a log.

    Parameters
    ----------
    log : WheelLog
        The log as recorded.
    pose_delay : float or "auto"
        ``d``, s, or ``"auto"`` to estimate it from the whole log
        (:func:`estimate_pose_delay`: an offline calibration).
    track_width : float
        Nominal track width ``B``, m.

    Returns
    -------
    (WheelLog, TimeCalibration)
        The log with its wheel speeds delayed (:func:`delay_wheel_speeds`) and
        the delay applied.

    Raises
    ------
    EstimationError
        ``auto`` on a log whose delay cannot be estimated.
    """
    estimate = estimate_pose_delay(log, track_width) if pose_delay == "auto" else None
    delay = estimate.delay if estimate is not None else float(pose_delay)
    return delay_wheel_speeds(log, delay), TimeCalibration(delay, estimate)
