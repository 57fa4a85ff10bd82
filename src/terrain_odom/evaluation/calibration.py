"""Self-calibration of a robot's own pose sensors against its wheels, from the whole log.

A consumer GPS and IMU come with a mounting and a latency nobody measured
and with message covariances that understate their noise. This module
finds them by comparing the positions with the path the wheels draw over
short windows of time:

- the *heading track* ``psi(s)`` at wheel time ``s``: the integrated ideal
  yaw ``k * integral (v_r - v_l) / B``, with the scale ``k`` of the measured
  heading's turn over 1-s intervals (moved by its delay) where the log has
  headings, else the one that best explains the positions (a skid-steer
  robot turns less than the ideal model). Not the measured heading itself:
  its slow wander bends the path within a window, which no rotation
  undoes, and biased the lever arm towards 0;
- the *wheel path* ``q(s) = integral (v_l + v_r) / 2 * exp(i psi) ds``
  (complex numbers: ``x + i y``), one per run;
- the positions ``m_k`` (the antenna's, stamped ``t_k``) are grouped into
  windows of ``window`` s, and each window is fitted, by linear least
  squares in complex numbers, with a similarity of the wheel path plus the
  lever arm ``a = antenna_x + i antenna_y`` common to the whole log::

      m_k = c_w q(t_k - d) + T_w + exp(i theta_k) a + n_k

  ``c_w`` (a rotation and a speed scale) and ``T_w`` absorb the heading
  offset, the slow wander of a heading and of a GPS bias, and the drift of
  dead reckoning; ``theta_k = psi_k + arg c_w`` is the robot's heading.

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

from terrain_odom.kinematics import wrap_angle
from terrain_odom.records import WheelLog

__all__ = [
    "CalibrationLimits",
    "Estimate",
    "LeverArm",
    "SensorFit",
    "circular_median",
    "correlation_time",
    "fit_sensors",
    "lever_significant",
    "run_time",
    "x_icr_limit",
]

_MAD = 1.4826
"""Ratio of the standard deviation to the median absolute deviation of a normal sample."""


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


def circular_median(angles: np.ndarray, weights: np.ndarray | None = None) -> float:
    """Return the (weighted) median of angles on the circle, rad in (-pi, pi].

    The angles are unwrapped around their circular mean first, so a cluster
    around +-pi is not split into two halves (a plain median of wrapped
    angles near +-pi falls between them).

    Examples
    --------
    >>> round(float(np.degrees(circular_median(np.radians([179.0, -179.0, 178.0])))), 6)
    179.0
    """
    a = np.asarray(angles, dtype=float)
    w = np.ones(a.size) if weights is None else np.asarray(weights, dtype=float)
    centre = float(np.angle(np.sum(w * np.exp(1j * a))))
    dev = wrap_angle(a - centre)
    return float(wrap_angle(centre + _weighted_median(dev, w)))


def _weighted_median(x: np.ndarray, w: np.ndarray) -> float:
    order = np.argsort(x)
    cum = np.cumsum(w[order])
    return float(x[order][np.searchsorted(cum, 0.5 * cum[-1])])


@dataclass(frozen=True)
class _Fixes:
    """Positions and the wheel path sampled for them."""

    t: np.ndarray  # stamps, s, on a time axis made increasing across runs
    m: np.ndarray  # measured positions, complex
    window: np.ndarray  # window id per fix, 0 .. W-1


@dataclass(frozen=True)
class _Track:
    """Wheel path and heading at the rows of the log (on the same time axis)."""

    t: np.ndarray
    q: np.ndarray  # complex wheel path, m
    psi: np.ndarray  # heading track, rad (unwrapped)


@dataclass(frozen=True)
class _WindowFit:
    """Result of :func:`_fit_windows` at one delay."""

    cost: float
    residual: np.ndarray  # complex, per fix
    c: np.ndarray  # complex, per window
    info: np.ndarray  # sum |q~|^2 per window, m^2
    a: complex
    a_info: np.ndarray  # 2x2 information of (a_x, a_y) per unit noise variance
    u_kept: float  # share of |u~|^2 left after projecting out the windows


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
    fixes = _fixes(log, time, lim)
    if has_heading:
        scale = _yaw_scale_from_headings(log, time, track_width, heading_delay)
    else:
        scale = _yaw_scale_from_positions(log, time, track_width, fixes, lim)
    # the wheels' turn, not the measured heading: a heading's slow wander bends the path
    # within a window, which no rotation undoes, and biases the lever arm towards 0
    track = _track(log, time, scale * _ideal_yaw(log, time, track_width))
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
    fit = _fit_windows(track, fixes, best, lever=True)
    lever = _with_delay_error(_lever_arm(fit), track, fixes, best, delay)
    offsets = (
        _window_offsets(track, fixes, fit, _measured_heading(log, time, heading_delay), delay)
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
    track: _Track, fixes: _Fixes, fit: _WindowFit, measured: np.ndarray, delay: Estimate
) -> np.ndarray:
    """Per window: circular mean of the measured heading minus the robot's at its fixes, rad.

    The robot's heading at a fix is the wheels' turn there plus the window's
    rotation ``arg c_w``; ``measured`` is the measured heading at the track's rows.
    """
    s = fixes.t - (delay.value if np.isfinite(delay.value) else 0.0)
    robot = np.interp(s, track.t, track.psi) + np.angle(fit.c[fixes.window])
    diff = np.exp(1j * (np.interp(s, track.t, measured) - robot))
    return np.angle(_wsum(diff, fixes.window, fit.c.size))


def _unobservable(why: str, scale: float, windows: int) -> SensorFit:
    e = Estimate(float("nan"), float("nan"), False, why)
    return SensorFit(e, e, e, e, e, e, e, scale, windows)


def _no_heading() -> Estimate:
    return Estimate(float("nan"), float("nan"), False, "the log has no headings")


def run_time(log: WheelLog) -> np.ndarray:
    """Return the log's times made increasing across runs, with a 1e6-s jump at each new run.

    On that time axis no window, chord or interpolation crosses from one run
    to the next (it jumps by far more than any of them spans).
    """
    jump = np.zeros(len(log))
    starts = log.run_starts()[1:]
    jump[starts] = log.t[starts - 1] - log.t[starts] + 1e6
    return log.t + np.cumsum(jump)


def _fixes(log: WheelLog, time: np.ndarray, lim: CalibrationLimits) -> _Fixes:
    """Positions grouped into windows of ``lim.window`` s (runs never share a window).

    A window is used with ``min_fixes`` positions spread over at least half
    its length.
    """
    rows = np.flatnonzero(log.has_position)
    t = time[rows]
    raw = np.floor(t / lim.window).astype(np.int64)
    _, window, counts = np.unique(raw, return_inverse=True, return_counts=True)
    span = np.zeros(counts.size)
    np.maximum.at(span, window, t - raw * lim.window)  # time covered (from the window's start)
    first = np.full(counts.size, np.inf)
    np.minimum.at(first, window, t - raw * lim.window)
    # enough fixes over at least half the window (a short run's similarity is not a rotation)
    keep = (counts[window] >= lim.min_fixes) & ((span - first)[window] >= 0.5 * lim.window)
    _, window = np.unique(window[keep], return_inverse=True)
    m = log.pose[rows[keep], 0] + 1j * log.pose[rows[keep], 1]
    return _Fixes(t[keep], m, window)


def _measured_heading(log: WheelLog, time: np.ndarray, delay: float) -> np.ndarray:
    """Measured heading at every row's wheel time, unwrapped (moved by its delay)."""
    rows = np.flatnonzero(log.has_yaw)
    yaw = np.unwrap(log.pose[rows, 2])
    return np.interp(time, time[rows] - delay, yaw)


def _ideal_yaw(log: WheelLog, time: np.ndarray, track_width: float) -> np.ndarray:
    """Integrated ideal differential-drive yaw at every row, rad (0 across run starts)."""
    dt = np.diff(time) * (np.diff(log.segment_runs()) == 0)
    return np.r_[0.0, np.cumsum((log.v_r - log.v_l)[:-1] / track_width * dt)]


def _track(log: WheelLog, time: np.ndarray, psi: np.ndarray) -> _Track:
    """Wheel path (speeds held, heading at each step's middle) at the rows."""
    dt = np.diff(time) * (np.diff(log.segment_runs()) == 0)
    speed = 0.5 * (log.v_l + log.v_r)[:-1]
    step = speed * dt * np.exp(1j * 0.5 * (psi[1:] + psi[:-1]))
    return _Track(time, np.r_[0.0, np.cumsum(step)], psi)


def _at(track: _Track, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Wheel path and heading at times ``s`` (linear between rows)."""
    q = np.interp(s, track.t, track.q.real) + 1j * np.interp(s, track.t, track.q.imag)
    return q, np.interp(s, track.t, track.psi)


def _centred(x: np.ndarray, window: np.ndarray, n: int) -> np.ndarray:
    """``x`` minus its window's mean (complex)."""
    count = np.bincount(window, minlength=n)
    mean = (
        np.bincount(window, x.real, minlength=n) + 1j * np.bincount(window, x.imag, minlength=n)
    ) / np.maximum(count, 1)
    return x - mean[window]


def _wsum(x: np.ndarray, window: np.ndarray, n: int) -> np.ndarray:
    """Sum of complex ``x`` per window."""
    return np.bincount(window, x.real, minlength=n) + 1j * np.bincount(window, x.imag, minlength=n)


def _fit_windows(
    track: _Track, fixes: _Fixes, delay: float, *, lever: bool, rounds: int = 3
) -> _WindowFit:
    """Fit ``m = c_w q + T_w (+ exp(i theta) a)`` at one position delay (see the module).

    With the lever arm, ``a`` is fitted jointly with the windows' ``c_w, T_w``
    (the windows projected out); the robot's heading in ``exp(i theta)``
    takes the rotations of the previous round, ``rounds`` times.
    """
    n = int(fixes.window.max()) + 1
    w = fixes.window
    q, psi = _at(track, fixes.t - delay)
    qc, mc = _centred(q, w, n), _centred(fixes.m, w, n)
    info = np.bincount(w, np.abs(qc) ** 2, minlength=n)
    c = _wsum(np.conj(qc) * mc, w, n) / np.maximum(info, 1e-12)
    r, a, a_info, kept = mc - c[w] * qc, 0j, np.zeros((2, 2)), 0.0
    for _ in range(rounds if lever else 0):
        uc = _centred(np.exp(1j * (psi + np.angle(c[w]))), w, n)
        # what is left of the regressor after each window's similarity: 0 on straight
        # stretches and steady arcs (the lever arm's information)
        u = uc - (_wsum(np.conj(qc) * uc, w, n) / np.maximum(info, 1e-12))[w] * qc
        design = _lever_design(u)
        a_info = design.T @ design
        kept = float(np.sum(np.abs(u) ** 2)) / max(float(np.sum(np.abs(uc) ** 2)), 1e-12)
        a = _lever(u, mc - c[w] * qc)
        c = _wsum(np.conj(qc) * (mc - a * uc), w, n) / np.maximum(info, 1e-12)
        r = mc - c[w] * qc - a * uc
    return _WindowFit(float(np.sum(np.abs(r) ** 2)), r, c, info, a, a_info, kept)


def _lever_design(u: np.ndarray) -> np.ndarray:
    """Real design of ``u a`` in ``(a_x, a_y)``: ``(u_re a_x - u_im a_y) + i (u_im a_x + u_re a_y)``."""
    return np.column_stack([np.concatenate([u.real, u.imag]), np.concatenate([-u.imag, u.real])])


def _lever(u: np.ndarray, r: np.ndarray) -> complex:
    """Least-squares ``a`` of ``r = u a`` (complex), 0 where ``u`` is all 0."""
    design = _lever_design(u)
    sol = np.linalg.lstsq(design, np.concatenate([r.real, r.imag]), rcond=None)[0]
    return complex(sol[0], sol[1])


def _position_delay(
    track: _Track, fixes: _Fixes, lim: CalibrationLimits, given: float | None
) -> Estimate:
    """Least-squares position delay: a grid, then a parabola fitted to the costs near its best."""
    if given is not None:
        return Estimate(float(given), 0.0, True, "given")

    def costs_at(delays: np.ndarray, rounds: int) -> np.ndarray:
        fits = (_fit_windows(track, fixes, d, lever=True, rounds=rounds) for d in delays)
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
    fit: _WindowFit, offsets: np.ndarray, fixes: _Fixes, lim: CalibrationLimits
) -> tuple[np.ndarray, np.ndarray] | None:
    """Heading offsets (rad) and weights of the windows moving enough; None if too few."""
    use = fit.info / np.maximum(np.bincount(fixes.window), 1) >= lim.min_extent**2
    if int(use.sum()) < lim.min_windows:
        return None
    return wrap_angle(offsets[use]), fit.info[use]


def _heading_offset(
    fit: _WindowFit, offsets: np.ndarray, fixes: _Fixes, lim: CalibrationLimits
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
    spread = _MAD * float(np.median(np.abs(dev)))
    std = spread * np.sqrt(correlation_time(dev) / rot.size)
    return Estimate(
        value,
        float(std),
        True,
        f"circular median of measured heading minus the wheel path's over {rot.size} windows",
    )


def correlation_time(x: np.ndarray) -> float:
    """Integrated autocorrelation time of a sequence, in samples (>= 1; Geyer's initial sum)."""
    x = x - np.mean(x)
    var = float(x @ x)
    if x.size < 4 or var == 0.0:
        return 1.0
    tau = 1.0
    for lag in range(1, x.size // 2):
        rho = float(x[:-lag] @ x[lag:]) / var
        if rho <= 0.0:
            break
        tau += 2.0 * rho
    return tau


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


def _lever_arm(fit: _WindowFit) -> LeverArm:
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
    lever: LeverArm, track: _Track, fixes: _Fixes, best: float, delay: Estimate, h: float = 0.05
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
    up = _fit_windows(track, fixes, best + h, lever=True).a
    down = _fit_windows(track, fixes, best - h, lever=True).a
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


def _position_noise(fit: _WindowFit, fixes: _Fixes) -> Estimate:
    """Robust standard deviation of the residual components, corrected for the parameters."""
    parts = np.concatenate([fit.residual.real, fit.residual.imag])
    n = parts.size
    dof = max(n - 4 * fit.c.size - 2, 1)
    value = _MAD * float(np.median(np.abs(parts))) * np.sqrt(n / dof)
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
    ideal = _ideal_yaw(log, time, track_width)
    a, b = rows[:-1][same], rows[1:][same]
    return wrap_angle(log.pose[b, 2] - log.pose[a, 2]), ideal[b] - ideal[a]


def _yaw_scale_from_headings(
    log: WheelLog, time: np.ndarray, track_width: float, delay: float, span: float = 1.0
) -> float:
    """Least-squares ratio of the measured heading's turn to the ideal turn over ``span`` s.

    The heading is moved by its ``delay`` first, and the turns are taken
    over chained intervals of ``span`` s, not between consecutive headings:
    over a tenth of a second a heading's latency or jitter decorrelates
    the two turns and shrinks the ratio.
    """
    measured = _measured_heading(log, time, delay)
    ideal = _ideal_yaw(log, time, track_width)
    rows = np.flatnonzero(np.r_[True, np.diff(np.floor(time / span)) != 0])
    same = np.diff(log.segment_runs()[rows]) == 0
    dm, di = np.diff(measured[rows])[same], np.diff(ideal[rows])[same]
    size = float(np.max(np.abs(di), initial=0.0))
    if not 0.0 < size < np.inf:
        return 1.0
    di = di / size  # any track width: the squares neither overflow nor underflow
    return float(dm @ di) / float(di @ di) / size


def _yaw_scale_from_positions(
    log: WheelLog, time: np.ndarray, track_width: float, fixes: _Fixes, lim: CalibrationLimits
) -> float:
    """Return the ideal yaw's scale that best explains the positions (grid, then parabola)."""
    if fixes.t.size == 0:
        return 1.0
    ideal = _ideal_yaw(log, time, track_width)
    low, high = lim.yaw_scales
    grid = np.arange(low, high + 1e-9, 0.05)
    costs = np.array(
        [_fit_windows(_track(log, time, k * ideal), fixes, 0.0, lever=False).cost for k in grid]
    )
    i = int(np.clip(np.argmin(costs), 1, grid.size - 2))
    den = costs[i - 1] - 2.0 * costs[i] + costs[i + 1]
    step = 0.5 * 0.05 * (costs[i - 1] - costs[i + 1]) / den if den > 0 else 0.0
    return float(grid[i] + np.clip(step, -0.05, 0.05))


def _heading_noise(log: WheelLog, time: np.ndarray, track_width: float, scale: float) -> Estimate:
    """White heading noise from consecutive heading increments against the wheels' turn."""
    measured, ideal = _heading_increments(log, time, track_width)
    if measured.size < 20:
        return Estimate(float("nan"), float("nan"), False, "fewer than 20 heading increments")
    r = measured - scale * ideal
    value = _MAD * float(np.median(np.abs(r - np.median(r)))) / np.sqrt(2.0)
    return Estimate(
        value,
        value / np.sqrt(measured.size),
        True,
        f"robust std of {measured.size} consecutive heading increments about the wheels' turn",
    )


def _heading_wander(
    fit: _WindowFit, offsets: np.ndarray, fixes: _Fixes, lim: CalibrationLimits
) -> Estimate:
    """Spread of the windows' heading offsets beyond their own standard errors (rad)."""
    moving = _moving(fit, offsets, fixes, lim)
    if moving is None:
        return Estimate(float("nan"), float("nan"), False, "too few moving windows")
    rot, weight = moving
    dev = wrap_angle(rot - circular_median(rot, weight))
    dof = max(2 * fit.residual.size - 4 * fit.c.size - 2, 1)
    own = fit.cost / dof / weight  # variance of each window's rotation, rad^2
    spread2 = (_MAD * float(np.median(np.abs(dev)))) ** 2
    value = float(np.sqrt(max(spread2 - float(np.median(own)), 0.0)))
    return Estimate(
        value,
        value / np.sqrt(2.0 * max(rot.size / correlation_time(dev), 1.0)),
        True,
        f"spread of the heading offset over {rot.size} windows beyond their own error",
    )
