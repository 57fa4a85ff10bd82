"""Self-calibration of a robot's own pose sensors against its wheels, from the whole log.

A consumer GPS and IMU come with a mounting and a latency nobody measured
and with message covariances that understate their noise. This module
finds them by comparing the positions with the path the wheels draw over
short windows of time (:mod:`~terrain_odom.evaluation.wheel_path`: the
heading track ``psi`` and the wheel path ``q``, not the measured heading
itself, whose slow wander bends the path within a window, which no rotation
undoes, and biased the lever arm towards 0; each window of positions
fitted as ``m_k = c_w q(t_k - d) + T_w + exp(i theta_k) a + n_k``, the lever
arm ``a`` common to the whole log).

What the fit gives:

- the position delay ``d`` (s; a fix stamped ``t`` was measured at wheel
  time ``t - d``): the least squared residual over a grid of ``d``,
  refined by a parabola; its standard error from the curvature;
- the heading offset: per window, the circular mean of the measured
  heading minus the robot's (``psi + arg c_w``) at its fixes; their
  circular median (weighted by how well each window fixes its rotation)
  is the offset, correct near +-180 deg; its standard error counts the
  windows as correlated as their sequence is;
- the lever arm ``a`` and its covariance. It is observable only where the
  heading turns *unevenly* within windows: on a straight stretch
  ``exp(i theta) a`` is a constant absorbed by ``T_w``, on an arc of
  constant curvature it is an affine function of the path absorbed by
  ``c_w`` and ``T_w``; what is left of the regressor after the windows'
  part is projected out is the information, and too little of it is
  reported as not observable instead of a meaningless standard error.
  The lever arm is measured from the point of the robot that does not
  slide sideways, ``(x_icr, (y_l + y_r) / 2)``: the antenna moves at
  ``(v - omega (l_y - (y_l + y_r) / 2), omega (l_x - x_icr))`` in the robot
  frame, so only ``l - (x_icr, (y_l + y_r) / 2)`` is identifiable from
  wheels and positions, never the split (:class:`LeverArm`). Its standard
  error includes the position delay's (they are fitted jointly). Up to
  ``max_antenna_std`` it is calibrated; beyond, up to ``max_coarse_std``,
  it is still applied (coarse) where significant (:func:`lever_significant`:
  the rule the run's check judges a lever arm left by);
- the position noise: a robust standard deviation (MAD) of the residual
  components, corrected for the parameters fitted;
- the heading noise: a robust standard deviation of the heading increments
  between consecutive headings minus ``k`` times the wheels' turn over them
  (white noise; over ~0.02 s neither slip nor wander shows), and the
  heading's slow *wander*: the spread of the windows' rotations beyond
  what the fit's own uncertainty explains.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from terrain_odom.evaluation.robust import MAD_TO_STD, circular_median, correlation_time
from terrain_odom.evaluation.wheel_path import (
    Fixes,
    Track,
    WindowFit,
    fit_windows,
    ideal_yaw,
    measured_heading,
    run_time,
    wheel_track,
    window_fixes,
    window_sum,
    yaw_scale_from_headings,
    yaw_scale_from_positions,
)
from terrain_odom.kinematics import wrap_angle
from terrain_odom.records import WheelLog

__all__ = [
    "CalibrationLimits",
    "Estimate",
    "LeverArm",
    "SensorFit",
    "fit_sensors",
    "lever_significant",
    "x_icr_limit",
]


@dataclass(frozen=True)
class CalibrationLimits:
    """Windows, grids and thresholds of :func:`fit_sensors`.

    Attributes
    ----------
    window : float
        Length of the windows of positions, s.
    min_fixes : int
        Fewest positions in a window that is used.
    min_extent : float
        Least RMS distance of a window's wheel path from its centre, m, for
        its rotation to count towards the heading offset.
    max_delay, coarse_step, step : float
        The position delay is searched in ``[-max_delay, max_delay]`` s on
        a grid of ``coarse_step`` s, then of ``step`` s within ``parabola``
        of the best.
    parabola : float
        A parabola is fitted to the costs within this many s of the best
        delay of the grid: its vertex is the estimate, its curvature the
        standard error.
    max_delay_std : float
        Largest standard error of an estimated delay, s.
    max_antenna_std : float
        Largest standard error of a lever arm component calibrated to its
        target, m.
    lever_fraction, min_lever : float
        A lever arm component with a larger standard error is still applied
        (coarse) where it is significant: beyond three standard errors and
        beyond the larger of this fraction of the track width and this many
        metres (:func:`x_icr_limit`; a smaller one is not told from a
        robot's own ``x_icr``). The check of a run judges what is left
        after the configured antenna by the same rule.
    max_coarse_std : float
        Largest standard error of a coarse lever arm component, m.
    min_windows : int
        Fewest usable windows for any estimate.
    yaw_scales : tuple of float
        Range of the scale ``k`` of the ideal yaw searched without headings.
    """

    window: float = 10.0
    min_fixes: int = 5
    min_extent: float = 0.5
    max_delay: float = 1.5
    coarse_step: float = 0.05
    step: float = 0.01
    parabola: float = 0.2
    max_delay_std: float = 0.15
    max_antenna_std: float = 0.1
    lever_fraction: float = 0.5
    min_lever: float = 0.35
    max_coarse_std: float = 1.0
    min_windows: int = 8
    yaw_scales: tuple[float, float] = (0.3, 1.5)


@dataclass(frozen=True)
class Estimate:
    """One calibrated value.

    Attributes
    ----------
    value : float
        The estimate (NaN when not observable), in the quantity's unit.
    std : float
        Its standard error (NaN when not observable, except a delay too
        uncertain to calibrate: its standard error, which the lever arm's
        includes).
    observable : bool
        Whether the log holds enough of the motion that reveals it.
    how : str
        How it was found, or why not (one line).
    """

    value: float
    std: float
    observable: bool
    how: str


@dataclass(frozen=True)
class LeverArm:
    """The lever arm as the least squares gives it, observable or not.

    Attributes
    ----------
    x, y : float
        Antenna minus the point that does not slide sideways (``x_icr``,
        ``(y_l + y_r) / 2``), robot frame, m (NaN without enough windows).
    std_x, std_y : float
        Standard errors, m (inf where the log does not turn unevenly).
    kept : float
        Share of the turning that is neither straight driving nor steady arcs.
    """

    x: float
    y: float
    std_x: float
    std_y: float
    kept: float


_NO_LEVER = LeverArm(float("nan"), float("nan"), float("inf"), float("inf"), 0.0)


@dataclass(frozen=True)
class SensorFit:
    """What :func:`fit_sensors` found (see the module).

    Attributes
    ----------
    position_delay : Estimate
        s.
    heading_offset : Estimate
        rad (NaN without headings).
    antenna_x, antenna_y : Estimate
        m, in the robot frame.
    position_noise : Estimate
        m per axis.
    heading_noise, heading_wander : Estimate
        rad (NaN without headings).
    yaw_scale : float
        Measured turn / ideal differential drive's turn.
    windows : int
        Windows of positions used.
    lever : LeverArm
        The least-squares lever arm behind ``antenna_x``, ``antenna_y``
        (what the checks judge).
    """

    position_delay: Estimate
    heading_offset: Estimate
    antenna_x: Estimate
    antenna_y: Estimate
    position_noise: Estimate
    heading_noise: Estimate
    heading_wander: Estimate
    yaw_scale: float
    windows: int
    lever: LeverArm = _NO_LEVER


def fit_sensors(
    log: WheelLog,
    track_width: float,
    *,
    heading_delay: float = 0.0,
    position_delay: float | None = None,
    limits: CalibrationLimits | None = None,
) -> SensorFit:
    """Calibrate a log's position and heading sensors against its wheels (see the module).

    Parameters
    ----------
    log : WheelLog
        Wheel speeds (m/s), positions (``x, y``) and optionally headings,
        as recorded (no delay applied).
    track_width : float
        Nominal track width ``B``, m.
    heading_delay : float
        Delay of the heading stamps, s (a heading stamped ``t`` was measured
        at wheel time ``t - heading_delay``), already known.
    position_delay : float, optional
        Delay of the position stamps, s; None estimates it.
    limits : CalibrationLimits, optional

    Returns
    -------
    SensorFit
        Estimates that the log cannot give are NaN, not observable, with
        the reason in their ``how``.
    """
    lim = limits or CalibrationLimits()
    time = run_time(log)
    has_heading = int(log.has_yaw.sum()) >= 2
    fixes = window_fixes(log, time, lim.window, lim.min_fixes)
    if has_heading:
        scale = yaw_scale_from_headings(log, time, track_width, heading_delay)
    else:
        scale = yaw_scale_from_positions(log, time, track_width, fixes, lim.yaw_scales)
    # the wheels' turn, not the measured heading: a heading's slow wander bends the path
    # within a window, which no rotation undoes, and biases the lever arm towards 0
    track = wheel_track(log, time, scale * ideal_yaw(log, time, track_width))
    used = int(np.unique(fixes.window).size)
    if used < lim.min_windows:
        return _unobservable(
            f"only {used} windows of {lim.window:g} s with {lim.min_fixes} positions over "
            f"{0.5 * lim.window:g} s or more (at least {lim.min_windows}; runs of the log "
            "shorter than that count none): record longer with positions while driving",
            scale,
            used,
        )
    delay = _position_delay(track, fixes, lim, position_delay)
    # the lever arm at the least-squares delay, also where its standard error is too large
    # to calibrate it (the two are fitted jointly; at a wrong delay the lever arm is wrong)
    best = delay.value if np.isfinite(delay.value) else 0.0
    fit = fit_windows(track, fixes, best, lever=True)
    lever = _with_delay_error(_lever_arm(fit), track, fixes, best, delay)
    offsets = (
        _window_offsets(track, fixes, fit, measured_heading(log, time, heading_delay), delay)
        if has_heading
        else None
    )
    return SensorFit(
        delay,
        _heading_offset(fit, offsets, fixes, lim) if offsets is not None else _no_heading(),
        *_antenna(lever, lim, track_width),
        _position_noise(fit, fixes),
        _heading_noise(log, time, track_width, scale) if has_heading else _no_heading(),
        _heading_wander(fit, offsets, fixes, lim) if offsets is not None else _no_heading(),
        scale,
        used,
        lever,
    )


def _window_offsets(
    track: Track, fixes: Fixes, fit: WindowFit, measured: np.ndarray, delay: Estimate
) -> np.ndarray:
    """Per window: circular mean of the measured heading minus the robot's at its fixes, rad.

    The robot's heading at a fix is the wheels' turn there plus the window's
    rotation ``arg c_w``; ``measured`` is the measured heading at the track's rows.
    """
    s = fixes.t - (delay.value if np.isfinite(delay.value) else 0.0)
    robot = np.interp(s, track.t, track.psi) + np.angle(fit.c[fixes.window])
    diff = np.exp(1j * (np.interp(s, track.t, measured) - robot))
    return np.angle(window_sum(diff, fixes.window, fit.c.size))


def _unobservable(why: str, scale: float, windows: int) -> SensorFit:
    e = Estimate(float("nan"), float("nan"), False, why)
    return SensorFit(e, e, e, e, e, e, e, scale, windows)


def _no_heading() -> Estimate:
    return Estimate(float("nan"), float("nan"), False, "the log has no headings")


def _position_delay(
    track: Track, fixes: Fixes, lim: CalibrationLimits, given: float | None
) -> Estimate:
    """Least-squares position delay: a grid, then a parabola fitted to the costs near its best."""
    if given is not None:
        return Estimate(float(given), 0.0, True, "given")

    def costs_at(delays: np.ndarray, rounds: int) -> np.ndarray:
        fits = (fit_windows(track, fixes, d, lever=True, rounds=rounds) for d in delays)
        return np.array([fit.cost for fit in fits])

    coarse = np.arange(-lim.max_delay, lim.max_delay + 0.5 * lim.coarse_step, lim.coarse_step)
    best = int(np.argmin(costs_at(coarse, 1)))  # where the minimum lies; refined below
    if best in (0, coarse.size - 1):
        return _delay_unobservable(
            f"the best position delay lies at the edge of +-{lim.max_delay:g} s", float("nan")
        )
    grid = coarse[best] + np.arange(-lim.parabola, lim.parabola + 0.5 * lim.step, lim.step)
    costs = costs_at(grid, 2)
    i = int(np.argmin(costs))
    near = np.abs(grid - grid[i]) <= lim.parabola + 1e-9
    curve = float(np.polyfit(grid[near] - grid[i], costs[near], 2)[0])
    dof = max(2 * fixes.t.size - 4 * (int(fixes.window.max()) + 1) - 2, 1)
    sigma2 = float(costs[i]) / dof  # noise variance per component, m^2
    std = float(np.sqrt(sigma2 / curve)) if curve > 0 else float("inf")
    # the vertex from the grid's best and its neighbours (a wide parabola misplaces a sharp
    # minimum); the curvature, for the standard error, from the wide one (robust to noise)
    j = int(np.clip(i, 1, grid.size - 2))
    c_minus, c_0, c_plus = costs[j - 1 : j + 2]
    bend = c_minus - 2.0 * c_0 + c_plus
    step = 0.5 * lim.step * (c_minus - c_plus) / bend if bend > 0 else 0.0
    value = float(grid[j] + np.clip(step, -lim.step, lim.step))
    if not std <= lim.max_delay_std:
        return _delay_unobservable(
            f"too little change of speed and heading against the position noise to time the "
            f"positions (standard error {std:.2f} s > {lim.max_delay_std:g} s)",
            value,
            std,  # too large to calibrate the delay; the lever arm's error includes it
        )
    return Estimate(
        value,
        std,
        True,
        f"least squares of {fixes.t.size} positions against the wheel path, delays "
        f"+-{lim.max_delay:g} s",
    )


def _delay_unobservable(why: str, value: float, std: float = float("nan")) -> Estimate:
    return Estimate(
        value,
        std,
        False,
        f"{why}: drive with starts, stops and turns, or give the delay in seconds",
    )


def _moving(
    fit: WindowFit, offsets: np.ndarray, fixes: Fixes, lim: CalibrationLimits
) -> tuple[np.ndarray, np.ndarray] | None:
    """Heading offsets (rad) and weights of the windows moving enough; None if too few."""
    use = fit.info / np.maximum(np.bincount(fixes.window), 1) >= lim.min_extent**2
    if int(use.sum()) < lim.min_windows:
        return None
    return wrap_angle(offsets[use]), fit.info[use]


def _heading_offset(
    fit: WindowFit, offsets: np.ndarray, fixes: Fixes, lim: CalibrationLimits
) -> Estimate:
    """Circular median of the windows' rotations (measured heading minus the robot's)."""
    moving = _moving(fit, offsets, fixes, lim)
    if moving is None:
        return Estimate(
            float("nan"),
            float("nan"),
            False,
            f"fewer than {lim.min_windows} windows of {lim.window:g} s moving "
            f"{lim.min_extent:g} m: drive further with positions and headings",
        )
    rot, weight = moving
    value = circular_median(rot, weight)
    dev = wrap_angle(rot - value)
    spread = MAD_TO_STD * float(np.median(np.abs(dev)))
    std = spread * np.sqrt(correlation_time(dev) / rot.size)
    return Estimate(
        value,
        float(std),
        True,
        f"circular median of measured heading minus the wheel path's over {rot.size} windows",
    )


def x_icr_limit(track_width: float, limits: CalibrationLimits | None = None) -> float:
    """Return the lever arm (m) beyond which it is told from a robot's own ``x_icr``.

    The larger of ``limits.lever_fraction`` of the track width and
    ``limits.min_lever`` (:class:`CalibrationLimits`).
    """
    lim = limits or CalibrationLimits()
    return max(lim.lever_fraction * track_width, lim.min_lever)


def lever_significant(value: float, std: float, track_width: float, lim: CalibrationLimits) -> bool:
    """Whether a lever arm component is beyond :func:`x_icr_limit` and three standard errors.

    A component with a standard error beyond ``lim.max_coarse_std`` is not
    (the log hardly turns unevenly: its least squares is anywhere).
    """
    beyond = abs(value) > max(x_icr_limit(track_width, lim), 3.0 * std)
    return bool(np.isfinite(value) and std <= lim.max_coarse_std and beyond)


def _lever_arm(fit: WindowFit) -> LeverArm:
    """Return the least-squares lever arm and its standard errors (inf where rank-deficient)."""
    dof = max(2 * fit.residual.size - 4 * fit.c.size - 2, 1)
    sigma2 = fit.cost / dof
    eig = np.linalg.eigvalsh(fit.a_info)
    if eig[0] <= 1e-9 * max(eig[-1], 1e-12):
        std = np.array([np.inf, np.inf])
    else:
        std = np.sqrt(sigma2 * np.diag(np.linalg.inv(fit.a_info)))
    return LeverArm(fit.a.real, fit.a.imag, float(std[0]), float(std[1]), fit.u_kept)


def _with_delay_error(
    lever: LeverArm, track: Track, fixes: Fixes, best: float, delay: Estimate, h: float = 0.05
) -> LeverArm:
    """Add the position delay's error to the lever arm's (they are fitted jointly).

    ``std^2 += (d a / d delay)^2 std_delay^2``, the slope by central
    differences over ``h`` s; inf where the delay's standard error is not
    known (a lever arm at an untimed delay can be anything).
    """
    if delay.std == 0.0:  # given
        return lever
    if not np.isfinite(delay.std):
        return dataclasses.replace(lever, std_x=float("inf"), std_y=float("inf"))
    up = fit_windows(track, fixes, best + h, lever=True).a
    down = fit_windows(track, fixes, best - h, lever=True).a
    slope = (up - down) / (2.0 * h)
    return dataclasses.replace(
        lever,
        std_x=float(np.hypot(lever.std_x, slope.real * delay.std)),
        std_y=float(np.hypot(lever.std_y, slope.imag * delay.std)),
    )


def _antenna(
    lever: LeverArm, lim: CalibrationLimits, track_width: float
) -> tuple[Estimate, Estimate]:
    """Return the lever arm as estimates: calibrated, coarse (significant), or not observable."""
    what = "(from the point that does not slide sideways: only antenna - x_icr is observable)"
    out = []
    for value, s, name in ((lever.x, lever.std_x, "x"), (lever.y, lever.std_y, "y")):
        if s <= lim.max_antenna_std:
            how = f"least squares of positions against the wheel path in uneven turns {what}"
            out.append(Estimate(float(value), float(s), True, how))
        elif lever_significant(value, s, track_width, lim):
            how = (
                f"coarse (standard error > {lim.max_antenna_std:g} m), applied as it is "
                f"significant: least squares of positions against the wheel path {what}; "
                "measure the antenna for better"
            )
            out.append(Estimate(float(value), float(s), True, how))
        else:
            out.append(
                Estimate(
                    float("nan"),
                    float("nan"),
                    False,
                    f"standard error of antenna_{name} {s:.2f} m > {lim.max_antenna_std:g} m "
                    f"and least squares gives {value:+.2f} m, within the noise or a robot's own "
                    f"x_icr ({100 * lever.kept:.0f} % of the turning is neither straight "
                    "driving nor steady arcs): drive longer, with S-bends and turns of "
                    "changing sharpness, or measure the antenna",
                )
            )
    return out[0], out[1]


def _position_noise(fit: WindowFit, fixes: Fixes) -> Estimate:
    """Robust standard deviation of the residual components, corrected for the parameters."""
    parts = np.concatenate([fit.residual.real, fit.residual.imag])
    n = parts.size
    dof = max(n - 4 * fit.c.size - 2, 1)
    value = MAD_TO_STD * float(np.median(np.abs(parts))) * np.sqrt(n / dof)
    return Estimate(
        value,
        value / np.sqrt(2.0 * dof),
        True,
        f"robust std of {fixes.t.size} positions about the wheel path ({fit.c.size} windows)",
    )


def _heading_increments(
    log: WheelLog, time: np.ndarray, track_width: float
) -> tuple[np.ndarray, np.ndarray]:
    """Measured heading change and ideal turn between consecutive headings of a run."""
    rows = np.flatnonzero(log.has_yaw)
    same = np.diff(log.segment_runs()[rows]) == 0
    ideal = ideal_yaw(log, time, track_width)
    a, b = rows[:-1][same], rows[1:][same]
    return wrap_angle(log.pose[b, 2] - log.pose[a, 2]), ideal[b] - ideal[a]


def _heading_noise(log: WheelLog, time: np.ndarray, track_width: float, scale: float) -> Estimate:
    """White heading noise from consecutive heading increments against the wheels' turn."""
    measured, ideal = _heading_increments(log, time, track_width)
    if measured.size < 20:
        return Estimate(float("nan"), float("nan"), False, "fewer than 20 heading increments")
    r = measured - scale * ideal
    value = MAD_TO_STD * float(np.median(np.abs(r - np.median(r)))) / np.sqrt(2.0)
    return Estimate(
        value,
        value / np.sqrt(measured.size),
        True,
        f"robust std of {measured.size} consecutive heading increments about the wheels' turn",
    )


def _heading_wander(
    fit: WindowFit, offsets: np.ndarray, fixes: Fixes, lim: CalibrationLimits
) -> Estimate:
    """Spread of the windows' heading offsets beyond their own standard errors (rad)."""
    moving = _moving(fit, offsets, fixes, lim)
    if moving is None:
        return Estimate(float("nan"), float("nan"), False, "too few moving windows")
    rot, weight = moving
    dev = wrap_angle(rot - circular_median(rot, weight))
    dof = max(2 * fit.residual.size - 4 * fit.c.size - 2, 1)
    own = fit.cost / dof / weight  # variance of each window's rotation, rad^2
    spread2 = (MAD_TO_STD * float(np.median(np.abs(dev)))) ** 2
    value = float(np.sqrt(max(spread2 - float(np.median(own)), 0.0)))
    return Estimate(
        value,
        value / np.sqrt(2.0 * max(rot.size / correlation_time(dev), 1.0)),
        True,
        f"spread of the heading offset over {rot.size} windows beyond their own error",
    )
