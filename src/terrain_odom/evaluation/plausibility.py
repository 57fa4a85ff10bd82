"""Plausibility of a wheel log: whether the wheels and the poses tell the same story.

Before anything is estimated, the wheel speeds are compared with the poses
of the same log, so the commonest mistakes stop a run with one line naming
the likely cause instead of giving a plausible-looking wrong answer:

- ``absurd_speed``: a wheel speed no ground robot reaches (a corrupt value,
  or angular speeds read as surface speeds in the wrong unit);
- ``time_step``: a median time step of more than a second or less than
  0.1 ms (milliseconds or microseconds read as seconds);
- ``still_wheels`` / ``still_poses``: the poses move while the wheels stand
  still over most of the log, or the reverse (wrong columns, or poses of
  another robot or run);
- ``travel``: distance from the wheels against distance from the positions
  far from 1 (wheel radius, rad/s against m/s), over chords of at least
  five noise standard deviations of wheel travel, each chord's length less
  the positions' noise (in quadrature): the noise of a GPS would otherwise
  lengthen a slow robot's measured path many times over;
- ``yaw_sign``: the heading turns against the wheels' turn (left and right
  swapped, or a clockwise yaw);
- ``yaw_follow``: the heading does not follow the wheels' turn at all, or
  turns many times faster (yaw in degrees, track width off by far);
- ``heading_offset`` / ``lever_arm``: the measured heading is off the
  positions' course on straight stretches, or the positions swing sideways
  in turns like a point far ahead of or behind the ICRs: a pose sensor's
  mounting left out of ``pose_sensor`` (:mod:`~terrain_odom.evaluation.mounting`).

Every quantity is compared over chained intervals of at least 0.5 s
between pose rows of one run of the log (never across a ``segment``
change), so a low pose rate, repeated poses, gaps and heading-only poses
are handled; a check without enough motion or turning to
judge is not made. The thresholds are loose: skid-steer robots slip
(the Warthog's heading turns at ~0.55 of the ideal differential drive's
rate, and it travels ~0.93 of its wheels' distance), and none of them fires
on the real logs in ``../shared/data/drive``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from terrain_odom.evaluation.mounting import MountingFit, fit_mounting, mounting_findings
from terrain_odom.evaluation.robust import MAD_TO_STD
from terrain_odom.kinematics import wrap_angle
from terrain_odom.records import WheelLog

__all__ = ["Finding", "Plausibility", "PlausibilityLimits", "check_log"]


@dataclass(frozen=True)
class PlausibilityLimits:
    """Thresholds of :func:`check_log` (units in the names' docs).

    Attributes
    ----------
    max_speed : float
        Fastest plausible track speed, m/s.
    time_step : tuple of float
        Plausible range of the median time step, s.
    span : float
        Shortest interval between two compared pose rows, s (bridges poses
        repeated until the sensor's next measurement).
    max_interval : float
        Longest interval between two compared pose rows, s (longer: a gap).
    moving_speed : float
        Speed above which the wheels or the poses count as moving, m/s.
    still_fraction : float
        Share of one side's moving time during which the other stands still
        that is reported.
    min_moving_time : float
        Least moving time (s) of one side for the still checks.
    travel_ratio : tuple of float
        Plausible range of pose distance / wheel distance.
    min_travel : float
        Least distance, m, from the wheels and from the poses, for the travel check.
    travel_chords : float
        Least wheel travel of a chord of the travel check, in standard
        deviations of the positions' noise.
    max_chord_time : float
        Longest chord of the travel check, s, where the noise asks for
        chords longer than ``max_interval`` (longer: a stop or a gap).
    min_turn : float
        Least total turn, rad, from the wheels and from the poses, for the yaw checks.
    min_correlation : float
        Least correlation of the heading changes with the wheels' turn.
    yaw_scale : tuple of float
        Plausible range of the fitted (measured turn) / (ideal turn) ratio.
    """

    max_speed: float = 30.0
    time_step: tuple[float, float] = (1e-4, 1.0)
    span: float = 0.5
    max_interval: float = 2.0
    moving_speed: float = 0.2
    still_fraction: float = 0.8
    min_moving_time: float = 10.0
    travel_ratio: tuple[float, float] = (0.5, 2.0)
    min_travel: float = 5.0
    travel_chords: float = 5.0
    max_chord_time: float = 60.0
    min_turn: float = 1.0
    min_correlation: float = 0.3
    yaw_scale: tuple[float, float] = (0.1, 3.0)


@dataclass(frozen=True)
class Finding:
    """One implausibility: which check, and a one-line message with the likely cause."""

    check: str
    message: str


@dataclass(frozen=True)
class Plausibility:
    """What :func:`check_log` measured, and what it found.

    Attributes
    ----------
    findings : tuple of Finding
        Empty when the log is plausible.
    median_step : float
        Median time step, s.
    max_speed : float
        Largest absolute track speed, m/s.
    wheel_travel, pose_travel : float
        Distances over the travel check's chords, m (0 without positions).
    yaw_scale, yaw_correlation : float
        Least-squares ratio of measured to ideal heading changes, and their
        correlation (NaN without headings).
    mounting : MountingFit or None
        Heading offset and apparent lever arm left after the configured
        mounting (None when the unit checks fired).
    """

    findings: tuple[Finding, ...]
    median_step: float
    max_speed: float
    wheel_travel: float
    pose_travel: float
    yaw_scale: float
    yaw_correlation: float
    mounting: MountingFit | None = None

    @property
    def ok(self) -> bool:
        """Whether no check fired."""
        return not self.findings


@dataclass(frozen=True)
class _Intervals:
    """Per interval between consecutive pose rows: duration, wheel and pose change."""

    dt: np.ndarray
    wheel_travel: np.ndarray
    pose_travel: np.ndarray
    wheel_turn: np.ndarray
    pose_turn: np.ndarray


def check_log(
    log: WheelLog,
    track_width: float,
    limits: PlausibilityLimits | None = None,
    *,
    antenna: tuple[float, float] = (0.0, 0.0),
    heading_offset: float = 0.0,
    position_noise: float = 0.0,
) -> Plausibility:
    """Compare a log's wheel speeds with its poses (see the module).

    Parameters
    ----------
    log : WheelLog
        The log, wheel speeds already in m/s.
    track_width : float
        Nominal track width ``B``, m: the wheels' turn is ``(v_r - v_l) / B``.
    limits : PlausibilityLimits, optional
        Thresholds (default: :class:`PlausibilityLimits`).
    antenna : tuple of 2 float
        Configured position antenna in the robot frame, m (``pose_sensor``).
    heading_offset : float
        Configured heading offset, rad.
    position_noise : float
        Standard deviation of the positions per axis, m, where known (the
        travel check takes it out of each chord's length).

    Returns
    -------
    Plausibility
    """
    lim = limits or PlausibilityLimits()
    step = float(np.median(np.diff(log.t))) if len(log) > 1 else float("nan")
    top = float(np.max(np.abs(np.r_[log.v_l, log.v_r]))) if len(log) else 0.0
    nan = float("nan")
    findings = _units(log, step, top, lim)
    if findings:  # the comparisons below would only repeat the unit mistake
        return Plausibility(tuple(findings), step, top, nan, nan, nan, nan)
    iv = _intervals(log, track_width, lim.span, lim.max_interval)
    pos, yaw = np.isfinite(iv.pose_travel), np.isfinite(iv.pose_turn)
    wheel_travel, pose_travel = _chord_travel(log, lim, position_noise)
    findings = _still(iv, pos, lim) or _travel(wheel_travel, pose_travel, lim)
    scale, corr = _yaw_fit(iv, yaw)
    findings += _yaw(iv, yaw, scale, corr, lim)
    mounting = fit_mounting(log, track_width, antenna=antenna, offset=heading_offset)
    if not findings:  # a unit or sign mistake would also show here: report it alone
        findings += [Finding(*f) for f in mounting_findings(mounting, track_width)]
    return Plausibility(
        tuple(findings),
        step,
        top,
        wheel_travel,
        pose_travel,
        scale,
        corr,
        mounting,
    )


def _units(log: WheelLog, step: float, top: float, lim: PlausibilityLimits) -> list[Finding]:
    out = []
    if top > lim.max_speed:
        k = int(np.argmax(np.maximum(np.abs(log.v_l), np.abs(log.v_r))))
        out.append(
            Finding(
                "absurd_speed",
                f"a track speed of {top:.3g} m/s at t = {log.t[k]:g} s is not a ground robot's "
                f"(> {lim.max_speed:g} m/s): a corrupt value, or speeds in another unit",
            )
        )
    low, high = lim.time_step
    if np.isfinite(step) and not low <= step <= high:
        cause = "milliseconds read as seconds?" if step > high else "microseconds or ticks?"
        out.append(
            Finding(
                "time_step",
                f"median time step {step:.3g} s is outside {low:g}-{high:g} s: times must be "
                f"seconds ({cause})",
            )
        )
    return out


def _chain(t: np.ndarray, span: float) -> np.ndarray:
    """Return indices into sorted ``t``: the first, then each next one at least ``span`` later."""
    chain = [0] if t.size else []
    while True:
        j = int(np.searchsorted(t, t[chain[-1]] + span)) if chain else t.size
        if j >= t.size:
            return np.array(chain, dtype=int)
        chain.append(j)


def _intervals(log: WheelLog, track_width: float, span: float, max_interval: float) -> _Intervals:
    """Wheel and pose changes over chained pose intervals of each run (see :func:`_chain`).

    Intervals of at least ``span`` s bridge poses that a log repeats until
    the sensor's next measurement.
    """
    parts: list[list[np.ndarray]] = [[] for _ in range(5)]
    for run in log.run_ranges():
        rows = np.arange(run.start, run.stop)
        t = log.t[rows]
        dt = np.diff(t)
        travel = np.r_[0.0, np.cumsum(0.5 * np.abs(log.v_l[rows] + log.v_r[rows])[:-1] * dt)]
        turn = np.r_[0.0, np.cumsum((log.v_r[rows] - log.v_l[rows])[:-1] / track_width * dt)]
        has = np.flatnonzero(np.isfinite(log.pose[rows, 0]) | np.isfinite(log.pose[rows, 2]))
        chain = has[_chain(t[has], span)]
        a, b = chain[:-1], chain[1:]
        keep = t[b] - t[a] <= max_interval
        a, b = a[keep], b[keep]
        pose = log.pose[rows]
        for i, values in enumerate(
            (
                t[b] - t[a],
                travel[b] - travel[a],
                np.hypot(*(pose[b, :2] - pose[a, :2]).T),
                turn[b] - turn[a],
                wrap_angle(pose[b, 2] - pose[a, 2]),
            )
        ):
            parts[i].append(values)
    return _Intervals(*(np.concatenate(p) if p else np.zeros(0) for p in parts))


def _still(iv: _Intervals, pos: np.ndarray, lim: PlausibilityLimits) -> list[Finding]:
    dt = iv.dt[pos]
    wheels = iv.wheel_travel[pos] / dt > lim.moving_speed
    poses = iv.pose_travel[pos] / dt > lim.moving_speed
    for moving, still, check, text in (
        (poses, ~wheels, "still_wheels", "the poses move while the wheels stand still"),
        (wheels, ~poses, "still_poses", "the wheels turn while the poses stand still"),
    ):
        time = float(np.sum(dt[moving]))
        share = float(np.sum(dt[moving & still])) / time if time > 0 else 0.0
        if time >= lim.min_moving_time and share >= lim.still_fraction:
            return [
                Finding(
                    check,
                    f"{text} over {100 * share:.0f} % of {time:.0f} s of motion: wrong wheel "
                    "columns, or poses of another run",
                )
            ]
    return []


def _position_noise(log: WheelLog) -> float:
    """Robust std of the positions per axis, m, from second differences of consecutive fixes.

    Over a few tenths of a second a robot's path is nearly straight at constant
    speed, so ``p_(k+1) - 2 p_k + p_(k-1)`` is mostly noise, of variance
    ``6 sigma^2`` (an upper bound where fixes are sparse or the robot turns).
    """
    parts = []
    for run in log.run_ranges():
        pose = log.pose[run.start : run.stop]
        xy = pose[np.isfinite(pose[:, 0]) & np.isfinite(pose[:, 1]), :2]
        if xy.shape[0] >= 3:
            parts.append((xy[2:] - 2.0 * xy[1:-1] + xy[:-2]).ravel())
    if not parts:
        return 0.0
    return MAD_TO_STD * float(np.median(np.abs(np.concatenate(parts)))) / np.sqrt(6.0)


def _chord_travel(log: WheelLog, lim: PlausibilityLimits, noise: float) -> tuple[float, float]:
    """Wheel travel and position travel over chained chords, m.

    Each chord runs from a position to the first one at least ``lim.span``
    s and ``travel_chords`` noise standard deviations of wheel travel later,
    within a run and ``max_chord_time`` s; its measured length loses
    ``2 sigma^2`` in quadrature (both ends are noisy). ``sigma`` is
    ``noise`` if given (> 0), else estimated (:func:`_position_noise`): a
    precise pose gives the short intervals of the other checks, a GPS chords
    of a few metres.
    """
    sigma = noise if noise > 0.0 else _position_noise(log)
    chord = lim.travel_chords * sigma
    wheel, pose = 0.0, 0.0
    for run in log.run_ranges():
        rows = np.arange(run.start, run.stop)
        t = log.t[rows]
        travel = np.r_[
            0.0, np.cumsum(0.5 * np.abs(log.v_l[rows] + log.v_r[rows])[:-1] * np.diff(t))
        ]
        fix = np.flatnonzero(np.isfinite(log.pose[rows, 0]) & np.isfinite(log.pose[rows, 1]))
        chain = fix[_chain(travel[fix], chord)] if chord > 0.0 else fix
        chain = chain[_chain(t[chain], lim.span)]
        a, b = chain[:-1], chain[1:]
        keep = t[b] - t[a] <= max(lim.max_chord_time if chord > 0.0 else lim.max_interval, 0.0)
        a, b = a[keep], b[keep]
        d2 = np.sum((log.pose[rows[b], :2] - log.pose[rows[a], :2]) ** 2, axis=1)
        wheel += float(np.sum(travel[b] - travel[a]))
        pose += float(np.sum(np.sqrt(np.maximum(d2 - 2.0 * sigma**2, 0.0))))
    return wheel, pose


def _travel(wheel: float, pose: float, lim: PlausibilityLimits) -> list[Finding]:
    if min(wheel, pose) < lim.min_travel:
        return []
    ratio = pose / wheel
    low, high = lim.travel_ratio
    if low <= ratio <= high:
        return []
    return [
        Finding(
            "travel",
            f"the poses travel {pose:.1f} m where the wheels say {wheel:.1f} m (x{ratio:.2f}): "
            "check the wheel radius, and whether the speeds are rad/s (omega_*) or m/s (v_*)",
        )
    ]


def _yaw_fit(iv: _Intervals, yaw: np.ndarray) -> tuple[float, float]:
    """Least-squares scale of measured to ideal heading changes, and their correlation.

    Both series are divided by their largest magnitude first, so a wheels'
    turn of any size (a track width of 1 mm or of 100 m) neither overflows
    nor underflows the sums of squares.
    """
    m, w = iv.pose_turn[yaw], iv.wheel_turn[yaw]
    m_top = float(np.max(np.abs(m), initial=0.0))
    w_top = float(np.max(np.abs(w), initial=0.0))
    if not (0.0 < m_top and 0.0 < w_top < np.inf):  # m: wrapped heading changes, |m| <= pi
        return float("nan"), float("nan")
    m, w = m / m_top, w / w_top
    mw, ww, mm = float(m @ w), float(w @ w), float(m @ m)
    return mw / ww * (m_top / w_top), mw / np.sqrt(ww * mm)


def _yaw(
    iv: _Intervals, yaw: np.ndarray, scale: float, corr: float, lim: PlausibilityLimits
) -> list[Finding]:
    """Judge the fitted turn ``scale`` and correlation ``corr`` (:func:`_yaw_fit`), if turned.

    Judged once the heading and the wheels both turned ``min_turn``, or the
    heading turned that much following the wheels' far smaller turn (a
    track width far too large: the wheels seem not to turn at all).
    """
    wheels = float(np.sum(np.abs(iv.wheel_turn[yaw])))
    heading = float(np.sum(np.abs(iv.pose_turn[yaw])))
    follows = corr >= lim.min_correlation and scale > lim.yaw_scale[1]
    if heading < lim.min_turn or (wheels < lim.min_turn and not follows):
        return []
    if corr <= -lim.min_correlation:
        return [
            Finding(
                "yaw_sign",
                f"the heading turns against the wheels (correlation {corr:.2f}): left and right "
                "wheels swapped, or yaw not counter-clockwise",
            )
        ]
    low, high = lim.yaw_scale
    if corr < lim.min_correlation:
        told = f"the heading does not follow the wheels' turn (correlation {corr:.2f}"
    elif not low <= scale <= high:
        told = f"the heading turns x{scale:.3g} as fast as the wheels say (correlation {corr:.2f}"
    else:
        return []
    return [Finding("yaw_follow", f"{told}): yaw in degrees, or a track width far off")]
