"""How the pose sensors are mounted, as the log shows it: heading offset and lever arm.

- Heading offset: over chords of the path between position measurements
  (each at least ``chord`` m of wheel travel long, like the course a GPS
  gives), with the measured heading at both ends, on straight chords (the
  wheels and the heading turn less than ``straight_turn`` from end to
  end), the measured heading (averaged along the chord, weighted by
  travel) minus the course of the chord is the sensor's heading offset
  left unexplained (an IMU mounted turned, the magnetic declination): its
  circular median over the log, its spread the robust standard deviation
  of the single chords. The configured offset is subtracted first.
- Lever arm: the one estimator of :func:`~terrain_odom.evaluation.calibration.fit_sensors`
  (what ``terrain-odom calibrate`` applies), on the log with its delays
  already applied (the position delay still left is fitted with it, as
  calibrate does). It measures the antenna from the point of the robot
  that does not slide sideways, ``(x_icr, (y_l + y_r) / 2)``: an antenna
  ``a`` m ahead of the reference point moves sideways in turns as if the
  robot's ``x_icr`` were ``a`` m further back, which is what an ICR EKF
  learns if the lever arm is left out. What is left after the configured
  antenna is judged by the rule calibrate applies a coarse lever arm by
  (:func:`~terrain_odom.evaluation.calibration.lever_significant`), so a
  lever arm calibrate applied, or found too small to tell, is never
  refused.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from terrain_odom.evaluation.calibration import (
    CalibrationLimits,
    Estimate,
    LeverArm,
    fit_sensors,
    lever_significant,
    x_icr_limit,
)
from terrain_odom.evaluation.robust import MAD_TO_STD, circular_median, correlation_time
from terrain_odom.evaluation.wheel_path import run_time
from terrain_odom.kinematics import wrap_angle
from terrain_odom.records import WheelLog

__all__ = [
    "MountingFit",
    "MountingLimits",
    "fit_mounting",
    "mounting_findings",
    "x_icr_limit",
]


@dataclass(frozen=True)
class MountingLimits:
    """Chords and thresholds of :func:`fit_mounting`.

    Attributes
    ----------
    chord : float
        Wheel travel between the two ends of a chord for the heading offset, m.
    max_chord_time : float
        Longest chord, s (longer: a gap or a stop).
    straight_turn : float
        Largest turn of a straight chord, rad (ideal wheels' turn and
        measured heading change from end to end; it may weave in between).
    min_moved : float
        Least chord length of a straight chord, as a fraction of the wheel
        travel along it (less: back and forth, or spinning on the spot).
    yaw_gap : float
        Largest time from a position to the nearest heading, s.
    min_straight : int
        Fewest straight chords for a heading offset.
    min_judged : int
        Fewest straight chords for the check to judge the heading offset
        (fewer, with a GPS's noise and a heading's slow wander, misjudge it
        by tens of degrees).
    heading_offset : float
        Heading offset beyond which the check reports, rad.
    lever : CalibrationLimits
        The lever arm's fit and the rule it is judged by.
    """

    chord: float = 3.0
    max_chord_time: float = 20.0
    straight_turn: float = 0.1
    min_moved: float = 0.7
    yaw_gap: float = 0.5
    min_straight: int = 5
    min_judged: int = 20
    heading_offset: float = float(np.radians(5.0))
    lever: CalibrationLimits = CalibrationLimits()


@dataclass(frozen=True)
class MountingFit:
    """What the chords of a log say about the pose sensors' mounting.

    Attributes
    ----------
    heading_offset : float
        Circular median of measured heading minus course over the straight chords, rad
        (NaN with fewer than ``min_straight``).
    heading_spread : float
        Robust standard deviation of that difference over single chords, rad.
    straight : int
        Straight chords.
    lever : LeverArm
        The lever arm as the log gives it (antenna minus the point that
        does not slide sideways), m.
    antenna : tuple of 2 float
        The configured antenna, m.
    correlation : float
        How many straight chords in a row are as one, from the correlation of
        their offsets in time order (a heading that wanders slowly, a GPS
        bias): the offset's standard error is ``spread sqrt(correlation /
        straight)``.
    windowed : Estimate or None
        The heading offset left after the configured one by calibrate's own
        fit (:func:`~terrain_odom.evaluation.calibration.fit_sensors`), rad;
        where it is observable the check judges it instead of the chords'.
    """

    heading_offset: float
    heading_spread: float
    straight: int
    lever: LeverArm
    antenna: tuple[float, float] = (0.0, 0.0)
    correlation: float = 1.0
    windowed: Estimate | None = None


@dataclass(frozen=True)
class _Chords:
    """Per chord: turns, heading against the course, straightness."""

    turn: np.ndarray  # measured, rad (sign flipped when reversing)
    wheel_turn: np.ndarray  # ideal wheels' turn, rad
    off_course: np.ndarray  # travel-weighted measured heading minus the chord's course, rad
    moved: np.ndarray  # length of the chord / wheel travel along it


def fit_mounting(
    log: WheelLog,
    track_width: float,
    *,
    antenna: tuple[float, float] = (0.0, 0.0),
    offset: float = 0.0,
    limits: MountingLimits | None = None,
) -> MountingFit:
    """Measure the heading offset and the lever arm left in a log (see the module).

    Parameters
    ----------
    log : WheelLog
        Wheel speeds (m/s) and poses (the sensors' antenna position and
        heading), the delays of the configuration applied.
    track_width : float
        Nominal track width, m (the wheels' turn of a chord).
    antenna : tuple of 2 float
        Configured antenna position in the robot frame, m.
    offset : float
        Configured heading offset, rad.
    limits : MountingLimits, optional

    Returns
    -------
    MountingFit
    """
    lim = limits or MountingLimits()
    arm = np.asarray(antenna, dtype=float)
    ch = _chords(log, track_width, arm, offset, lim)
    straight = (np.abs(ch.turn) < lim.straight_turn) & (np.abs(ch.wheel_turn) < lim.straight_turn)
    straight &= ch.moved > lim.min_moved
    course = ch.off_course[straight]
    nan = float("nan")
    value, spread, correlation = nan, nan, 1.0
    if course.size >= lim.min_straight:
        value = circular_median(course)  # near +-180 deg a plain median splits the cluster
        spread = float(MAD_TO_STD * np.median(np.abs(wrap_angle(course - value))))
        correlation = correlation_time(wrap_angle(course - value))
    # at the least-squares position delay left in the log, as calibrate fits it
    sensors = fit_sensors(log, track_width, limits=lim.lever)
    configured = (float(arm[0]), float(arm[1]))
    est = sensors.heading_offset
    windowed = None
    if est.observable:
        windowed = Estimate(float(wrap_angle(est.value - offset)), est.std, True, est.how)
    return MountingFit(
        value, spread, int(course.size), sensors.lever, configured, correlation, windowed
    )


def _heading_at(t: np.ndarray, yaw: np.ndarray, at: np.ndarray, gap: float) -> np.ndarray:
    """Interpolate measured headings (unwrapped) at times ``at``; NaN beyond ``gap`` s."""
    ok = np.isfinite(yaw)
    if not ok.any():
        return np.full(at.size, np.nan)
    ty, unwrapped = t[ok], np.unwrap(yaw[ok])
    out = np.interp(at, ty, unwrapped)
    near = np.abs(ty[np.clip(np.searchsorted(ty, at), 0, ty.size - 1)] - at)
    near = np.minimum(near, np.abs(ty[np.clip(np.searchsorted(ty, at) - 1, 0, ty.size - 1)] - at))
    return np.where(near <= gap, out, np.nan)


def _chords(
    log: WheelLog,
    track_width: float,
    antenna: np.ndarray,
    offset: float,
    lim: MountingLimits,
) -> _Chords:
    """Chords from every position row to the first ``lim.chord`` m of wheel travel later.

    All runs at once: on a time axis that jumps by far more than any chord
    or heading gap between runs, and with no travel or turn across a run's
    end, so no chord and no interpolated heading crosses from one run to the
    next.
    """
    if len(log) < 2:
        return _Chords(*(np.zeros(0) for _ in range(4)))
    t = run_time(log)
    dt = np.diff(t) * (np.diff(log.segment_runs()) == 0)
    speed = 0.5 * (log.v_l + log.v_r)[:-1]
    signed = np.r_[0.0, np.cumsum(speed * dt)]
    turn = np.r_[0.0, np.cumsum((log.v_r - log.v_l)[:-1] / track_width * dt)]
    fix = np.flatnonzero(np.isfinite(log.pose[:, 0]) & np.isfinite(log.pose[:, 1]))
    travel = np.r_[0.0, np.cumsum(np.abs(speed) * dt)][fix]
    yaw = _heading_at(t, log.pose[:, 2], t[fix], lim.yaw_gap) - offset  # unwrapped
    c, s = np.cos(yaw), np.sin(yaw)
    xy = log.pose[fix, :2] - np.column_stack(
        [c * antenna[0] - s * antenna[1], s * antenna[0] + c * antenna[1]]
    )
    # travel-weighted heading along the path: a chord's course, however it weaves
    step = np.nan_to_num(0.5 * (yaw[1:] + yaw[:-1])) * np.diff(travel)
    area, gaps = np.r_[0.0, np.cumsum(step)], np.r_[0, np.cumsum(~np.isfinite(yaw))]
    j = np.searchsorted(travel, travel + lim.chord)
    i = np.flatnonzero(j < fix.size)
    j = j[i]
    keep = (t[fix[j]] - t[fix[i]] <= lim.max_chord_time) & (gaps[j + 1] == gaps[i])
    i, j = i[keep], j[keep]
    dyaw = yaw[j] - yaw[i]
    d = xy[j] - xy[i]
    back = np.where(signed[fix[j]] < signed[fix[i]], -1.0, 1.0)  # reversing: course + pi
    heading = (area[j] - area[i]) / (travel[j] - travel[i])
    off_course = wrap_angle(heading - np.arctan2(back * d[:, 1], back * d[:, 0]))
    moved = np.hypot(d[:, 0], d[:, 1]) / (travel[j] - travel[i])
    return _Chords(back * dyaw, turn[fix[j]] - turn[fix[i]], off_course, moved)


def mounting_findings(
    fit: MountingFit, track_width: float, limits: MountingLimits | None = None
) -> list[tuple[str, str]]:
    """Return ``(check, message)`` for a heading offset or lever arm left unexplained.

    A heading offset is reported beyond ``limits.heading_offset`` and three
    standard errors of its median (the chords counted as correlated as they
    are); a lever arm component left after the configured antenna beyond
    :func:`x_icr_limit` and three standard errors (the rule by which
    calibrate applies one).
    """
    lim = limits or MountingLimits()
    out = []
    if fit.windowed is not None:  # calibrate's own fit: what it applied is left as 0
        off, std = fit.windowed.value, fit.windowed.std
        if abs(off) > max(lim.heading_offset, 3.76 * std):
            out.append(("heading_offset", _heading_message(off, std)))
        off = float("nan")  # the chords are not judged
    else:  # a log too short for calibrate's windows: the straight chords, as calibrate then
        off = fit.heading_offset
    n = fit.straight
    std = fit.heading_spread * (fit.correlation / n) ** 0.5 if n else float("nan")
    judged = np.isfinite(off) and n >= lim.min_judged
    if judged and abs(off) > max(lim.heading_offset, 3.76 * std):
        out.append(
            (
                "heading_offset",
                f"the measured heading is {np.degrees(off):+.1f} deg off the course of the "
                f"positions on {n} straight stretches (spread {np.degrees(fit.heading_spread):.1f}"
                " deg): a heading sensor mounted turned, or magnetic declination; set "
                "pose_sensor.heading_offset (radians, or auto)",
            )
        )
    lever = fit.lever
    for name, value, se, configured in (
        ("x", lever.x, lever.std_x, fit.antenna[0]),
        ("y", lever.y, lever.std_y, fit.antenna[1]),
    ):
        if lever_significant(value - configured, se, track_width, lim.lever):
            tells = lever_significant(value, se, track_width, lim.lever)
            out.append(("lever_arm", _lever_message(name, value, se, configured, tells)))
    return out


def _lever_message(name: str, value: float, std: float, configured: float, tells: bool) -> str:
    """One line: where the positions put the antenna, against the configured one.

    ``tells``: whether the log's lever arm is itself significant (what
    calibrate would apply); else it cannot be told from 0 and the way out
    is to measure the antenna.
    """
    where = (
        f"in turns the positions swing as from an antenna at {name} = {value:+.2f} m "
        f"(+-{std:.2f}) from the point that does not slide sideways, "
        f"{value - configured:+.2f} m from pose_sensor.antenna_{name} {configured:+.2f}"
    )
    if tells:
        return f"{where}: set it to {value:+.2f}, or to auto (terrain-odom calibrate finds it)"
    return f"{where}: measure the antenna (the log cannot tell it from 0), or set 0"


def _heading_message(off: float, std: float) -> str:
    """One line: the heading offset calibrate's fit leaves after the configured one."""
    return (
        f"the measured heading is {np.degrees(off):+.1f} deg (+-{np.degrees(std):.1f}) off the "
        "robot's against the wheel path in windows of positions: a heading sensor mounted "
        "turned, or magnetic declination; add it to pose_sensor.heading_offset (radians), or "
        "set auto (terrain-odom calibrate finds it)"
    )
