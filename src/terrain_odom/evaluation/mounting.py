"""How the pose sensors are mounted, as the log shows it: heading offset and lever arm.

Over chords of the path between position measurements (each at least
``chord`` m of wheel travel long, like the course a GPS gives), with the
measured heading at both ends:

- on straight chords (the wheels and the heading turn less than
  ``straight_turn`` from end to end), the measured heading (averaged
  along the chord, weighted by travel) minus the course of the chord is
  the sensor's heading offset left unexplained (an IMU mounted turned,
  the magnetic declination): its circular median over the log, its spread
  the robust standard deviation of the single chords;
- on every chord, the sideways displacement in the frame of the mean
  heading is ``-x * dyaw`` for a point whose velocity is ``-x * omega``
  sideways: the apparent ``x_icr`` of the position sensor. A GPS antenna
  ``a`` m ahead of the reference point adds ``-a`` to the robot's own
  ``x_icr``: that is what an ICR EKF learns if the lever arm is left out.

The configured mounting is applied first (the heading offset subtracted,
the antenna moved to the reference point), so the figures are what is
left unexplained.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from terrain_odom.evaluation.calibration import circular_median, correlation_time, run_time
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
    lever_chord : float
        The same for the lever arm, m (shorter: the sideways displacement
        is ``-x * dyaw`` only while the turn of a chord is small).
    max_chord_time : float
        Longest chord, s (longer: a gap or a stop).
    straight_turn : float
        Largest turn of a straight chord, rad (ideal wheels' turn and
        measured heading change from end to end; it may weave in between).
    min_moved : float
        Least chord length of a straight chord, as a fraction of the wheel
        travel along it (less: back and forth, or spinning on the spot).
    max_turn : float
        Largest measured turn of a chord in the lever-arm fit, rad.
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
    x_icr_fraction, min_x_icr : float
        Apparent ``|x_icr|`` beyond which the check reports: the larger of
        this fraction of the track width and this many metres (a smaller
        lever arm is not told from a robot's own ``x_icr``).
    """

    chord: float = 3.0
    lever_chord: float = 2.0
    max_chord_time: float = 20.0
    straight_turn: float = 0.1
    min_moved: float = 0.7
    max_turn: float = 1.0
    yaw_gap: float = 0.5
    min_straight: int = 5
    min_judged: int = 20
    heading_offset: float = float(np.radians(5.0))
    x_icr_fraction: float = 0.5
    min_x_icr: float = 0.35


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
    x_icr : float
        Apparent ICR ``x`` of the position sensor, m (NaN without turning chords).
    x_icr_std : float
        Its standard error, m.
    chords : int
        Chords with a heading at both ends.
    correlation : float
        How many straight chords in a row are as one, from the correlation of
        their offsets in time order (a heading that wanders slowly, a GPS
        bias): the offset's standard error is ``spread sqrt(correlation /
        straight)``.
    """

    heading_offset: float
    heading_spread: float
    straight: int
    x_icr: float
    x_icr_std: float
    chords: int
    correlation: float = 1.0


@dataclass(frozen=True)
class _Chords:
    """Per chord: forward and sideways displacement in the mean heading's frame, turns."""

    forward: np.ndarray
    lateral: np.ndarray
    turn: np.ndarray  # measured, rad (sign flipped when reversing, as the displacements)
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
    """Measure the heading offset and the apparent lever arm left in a log (see the module).

    Parameters
    ----------
    log : WheelLog
        Wheel speeds (m/s) and poses (the sensors' antenna position and heading).
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
    ch = _chords(log, track_width, arm, offset, lim, lim.chord)
    straight = (np.abs(ch.turn) < lim.straight_turn) & (np.abs(ch.wheel_turn) < lim.straight_turn)
    straight &= ch.moved > lim.min_moved
    course = ch.off_course[straight]
    nan = float("nan")
    value, spread, correlation = nan, nan, 1.0
    if course.size >= lim.min_straight:
        value = circular_median(course)  # near +-180 deg a plain median splits the cluster
        spread = float(1.4826 * np.median(np.abs(wrap_angle(course - value))))
        correlation = correlation_time(wrap_angle(course - value))
    lever = _chords(log, track_width, arm, offset, lim, lim.lever_chord)
    x_icr, x_std = _lever_arm(lever, lim)
    return MountingFit(
        value, spread, int(course.size), x_icr, x_std, int(lever.turn.size), correlation
    )


def _lever_arm(ch: _Chords, lim: MountingLimits) -> tuple[float, float]:
    """Least squares of ``lateral = s * forward - x * turn``; return ``x`` and its std error."""
    keep = np.abs(ch.turn) < lim.max_turn
    a = np.column_stack([ch.forward[keep], -ch.turn[keep]])
    b = ch.lateral[keep]
    if b.size < 3 or np.sum(np.abs(ch.turn[keep])) < 1.0:
        return float("nan"), float("nan")
    coef, *_ = np.linalg.lstsq(a, b, rcond=None)
    dof = max(b.size - 2, 1)
    sigma2 = float(np.sum((b - a @ coef) ** 2)) / dof
    cov = 2.0 * sigma2 * np.linalg.pinv(a.T @ a)  # each fix ends one chord, starts another
    return float(coef[1]), float(np.sqrt(cov[1, 1]))


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
    chord: float,
) -> _Chords:
    """Chords from every position row to the first ``chord`` m of wheel travel later.

    All runs at once: on a time axis that jumps by far more than any chord
    or heading gap between runs, and with no travel or turn across a run's
    end, so no chord and no interpolated heading crosses from one run to the
    next.
    """
    if len(log) < 2:
        return _Chords(*(np.zeros(0) for _ in range(6)))
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
    j = np.searchsorted(travel, travel + chord)
    i = np.flatnonzero(j < fix.size)
    j = j[i]
    keep = (t[fix[j]] - t[fix[i]] <= lim.max_chord_time) & (gaps[j + 1] == gaps[i])
    i, j = i[keep], j[keep]
    dyaw = yaw[j] - yaw[i]
    mid = yaw[i] + 0.5 * dyaw
    d = xy[j] - xy[i]
    back = np.where(signed[fix[j]] < signed[fix[i]], -1.0, 1.0)  # reversing: course + pi
    forward = back * (np.cos(mid) * d[:, 0] + np.sin(mid) * d[:, 1])
    lateral = back * (-np.sin(mid) * d[:, 0] + np.cos(mid) * d[:, 1])
    heading = (area[j] - area[i]) / (travel[j] - travel[i])
    off_course = wrap_angle(heading - np.arctan2(back * d[:, 1], back * d[:, 0]))
    moved = np.hypot(d[:, 0], d[:, 1]) / (travel[j] - travel[i])
    return _Chords(forward, lateral, back * dyaw, turn[fix[j]] - turn[fix[i]], off_course, moved)


def x_icr_limit(track_width: float, limits: MountingLimits | None = None) -> float:
    """Return the ``|x_icr|`` (m) beyond which a lever arm is suspected (see :class:`MountingLimits`)."""
    lim = limits or MountingLimits()
    return max(lim.x_icr_fraction * track_width, lim.min_x_icr)


def mounting_findings(
    fit: MountingFit, track_width: float, limits: MountingLimits | None = None
) -> list[tuple[str, str]]:
    """Return ``(check, message)`` for a heading offset or lever arm left unexplained.

    A heading offset is reported beyond ``limits.heading_offset`` and three
    standard errors of its median (the chords counted as correlated as they
    are); an apparent ``|x_icr|`` beyond
    :func:`x_icr_limit` and three standard errors.
    """
    lim = limits or MountingLimits()
    out = []
    off, n = fit.heading_offset, fit.straight
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
    x = fit.x_icr
    if np.isfinite(x) and abs(x) > max(x_icr_limit(track_width, lim), 3.0 * fit.x_icr_std):
        where = "behind" if x < 0 else "ahead of"
        out.append(
            (
                "lever_arm",
                f"in turns the positions move sideways as if the ICRs were {abs(x):.2f} m "
                f"(+-{fit.x_icr_std:.2f}) {where} the reference point: a position antenna "
                f"{abs(x):.2f} m {'ahead of' if x < 0 else 'behind'} it? set pose_sensor.antenna_x",
            )
        )
    return out
