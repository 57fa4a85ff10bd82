"""The wheel path and the least squares of positions against it, window by window.

What :func:`~terrain_odom.evaluation.calibration.fit_sensors` compares the
positions with (the module there says what it finds from the fit):

- the *heading track* ``psi(s)`` at wheel time ``s``: the integrated ideal
  yaw ``k * integral (v_r - v_l) / B`` (:func:`ideal_yaw`), with the scale
  ``k`` of the measured heading's turn over 1-s intervals (moved by its
  delay: :func:`yaw_scale_from_headings`) where the log has headings, else
  the one that best explains the positions (:func:`yaw_scale_from_positions`;
  a skid-steer robot turns less than the ideal model);
- the *wheel path* ``q(s) = integral (v_l + v_r) / 2 * exp(i psi) ds``
  (complex numbers: ``x + i y``), one per run (:func:`wheel_track`);
- the positions ``m_k`` (the antenna's, stamped ``t_k``) are grouped into
  windows of a few seconds (:func:`window_fixes`), and each window is
  fitted, by linear least squares in complex numbers, with a similarity of
  the wheel path plus the lever arm ``a = antenna_x + i antenna_y`` common
  to the whole log (:func:`fit_windows`)::

      m_k = c_w q(t_k - d) + T_w + exp(i theta_k) a + n_k

  ``c_w`` (a rotation and a speed scale) and ``T_w`` absorb the heading
  offset, the slow wander of a heading and of a GPS bias, and the drift of
  dead reckoning; ``theta_k = psi_k + arg c_w`` is the robot's heading.

Every time is on the log's :func:`run_time` axis, on which no window, chord
or interpolation crosses from one run to the next.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from terrain_odom.records import WheelLog

__all__ = [
    "Fixes",
    "Track",
    "WindowFit",
    "fit_windows",
    "ideal_yaw",
    "measured_heading",
    "run_time",
    "wheel_track",
    "window_fixes",
    "window_sum",
    "yaw_scale_from_headings",
    "yaw_scale_from_positions",
]


@dataclass(frozen=True)
class Fixes:
    """Positions and the wheel path sampled for them."""

    t: np.ndarray  # stamps, s, on a time axis made increasing across runs
    m: np.ndarray  # measured positions, complex
    window: np.ndarray  # window id per fix, 0 .. W-1


@dataclass(frozen=True)
class Track:
    """Wheel path and heading at the rows of the log (on the same time axis)."""

    t: np.ndarray
    q: np.ndarray  # complex wheel path, m
    psi: np.ndarray  # heading track, rad (unwrapped)


@dataclass(frozen=True)
class WindowFit:
    """Result of :func:`fit_windows` at one delay."""

    cost: float
    residual: np.ndarray  # complex, per fix
    c: np.ndarray  # complex, per window
    info: np.ndarray  # sum |q~|^2 per window, m^2
    a: complex
    a_info: np.ndarray  # 2x2 information of (a_x, a_y) per unit noise variance
    u_kept: float  # share of |u~|^2 left after projecting out the windows


def run_time(log: WheelLog) -> np.ndarray:
    """Return the log's times made increasing across runs, with a 1e6-s jump at each new run.

    On that time axis no window, chord or interpolation crosses from one run
    to the next (it jumps by far more than any of them spans).
    """
    jump = np.zeros(len(log))
    starts = log.run_starts()[1:]
    jump[starts] = log.t[starts - 1] - log.t[starts] + 1e6
    return log.t + np.cumsum(jump)


def window_fixes(log: WheelLog, time: np.ndarray, length: float, min_fixes: int) -> Fixes:
    """Positions grouped into windows of ``length`` s (runs never share a window).

    A window is used with ``min_fixes`` positions spread over at least half
    its length. ``time`` is the log's :func:`run_time`.
    """
    rows = np.flatnonzero(log.has_position)
    t = time[rows]
    raw = np.floor(t / length).astype(np.int64)
    _, window, counts = np.unique(raw, return_inverse=True, return_counts=True)
    span = np.zeros(counts.size)
    np.maximum.at(span, window, t - raw * length)  # time covered (from the window's start)
    first = np.full(counts.size, np.inf)
    np.minimum.at(first, window, t - raw * length)
    # enough fixes over at least half the window (a short run's similarity is not a rotation)
    keep = (counts[window] >= min_fixes) & ((span - first)[window] >= 0.5 * length)
    _, window = np.unique(window[keep], return_inverse=True)
    m = log.pose[rows[keep], 0] + 1j * log.pose[rows[keep], 1]
    return Fixes(t[keep], m, window)


def measured_heading(log: WheelLog, time: np.ndarray, delay: float) -> np.ndarray:
    """Measured heading at every row's wheel time, unwrapped (moved by its delay)."""
    rows = np.flatnonzero(log.has_yaw)
    yaw = np.unwrap(log.pose[rows, 2])
    return np.interp(time, time[rows] - delay, yaw)


def ideal_yaw(log: WheelLog, time: np.ndarray, track_width: float) -> np.ndarray:
    """Integrated ideal differential-drive yaw at every row, rad (0 across run starts)."""
    dt = np.diff(time) * (np.diff(log.segment_runs()) == 0)
    return np.r_[0.0, np.cumsum((log.v_r - log.v_l)[:-1] / track_width * dt)]


def wheel_track(log: WheelLog, time: np.ndarray, psi: np.ndarray) -> Track:
    """Wheel path (speeds held, heading at each step's middle) at the rows."""
    dt = np.diff(time) * (np.diff(log.segment_runs()) == 0)
    speed = 0.5 * (log.v_l + log.v_r)[:-1]
    step = speed * dt * np.exp(1j * 0.5 * (psi[1:] + psi[:-1]))
    return Track(time, np.r_[0.0, np.cumsum(step)], psi)


def _at(track: Track, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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


def window_sum(x: np.ndarray, window: np.ndarray, n: int) -> np.ndarray:
    """Sum of complex ``x`` per window."""
    return np.bincount(window, x.real, minlength=n) + 1j * np.bincount(window, x.imag, minlength=n)


def fit_windows(
    track: Track, fixes: Fixes, delay: float, *, lever: bool, rounds: int = 3
) -> WindowFit:
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
    c = window_sum(np.conj(qc) * mc, w, n) / np.maximum(info, 1e-12)
    r, a, a_info, kept = mc - c[w] * qc, 0j, np.zeros((2, 2)), 0.0
    for _ in range(rounds if lever else 0):
        uc = _centred(np.exp(1j * (psi + np.angle(c[w]))), w, n)
        # what is left of the regressor after each window's similarity: 0 on straight
        # stretches and steady arcs (the lever arm's information)
        u = uc - (window_sum(np.conj(qc) * uc, w, n) / np.maximum(info, 1e-12))[w] * qc
        design = _lever_design(u)
        a_info = design.T @ design
        kept = float(np.sum(np.abs(u) ** 2)) / max(float(np.sum(np.abs(uc) ** 2)), 1e-12)
        a = _lever(u, mc - c[w] * qc)
        c = window_sum(np.conj(qc) * (mc - a * uc), w, n) / np.maximum(info, 1e-12)
        r = mc - c[w] * qc - a * uc
    return WindowFit(float(np.sum(np.abs(r) ** 2)), r, c, info, a, a_info, kept)


def _lever_design(u: np.ndarray) -> np.ndarray:
    """Real design of ``u a`` in ``(a_x, a_y)``: ``(u_re a_x - u_im a_y) + i (u_im a_x + u_re a_y)``."""
    return np.column_stack([np.concatenate([u.real, u.imag]), np.concatenate([-u.imag, u.real])])


def _lever(u: np.ndarray, r: np.ndarray) -> complex:
    """Least-squares ``a`` of ``r = u a`` (complex), 0 where ``u`` is all 0."""
    design = _lever_design(u)
    sol = np.linalg.lstsq(design, np.concatenate([r.real, r.imag]), rcond=None)[0]
    return complex(sol[0], sol[1])


def yaw_scale_from_headings(
    log: WheelLog, time: np.ndarray, track_width: float, delay: float, span: float = 1.0
) -> float:
    """Least-squares ratio of the measured heading's turn to the ideal turn over ``span`` s.

    The heading is moved by its ``delay`` first, and the turns are taken
    over chained intervals of ``span`` s, not between consecutive headings:
    over a tenth of a second a heading's latency or jitter decorrelates
    the two turns and shrinks the ratio.
    """
    measured = measured_heading(log, time, delay)
    ideal = ideal_yaw(log, time, track_width)
    rows = np.flatnonzero(np.r_[True, np.diff(np.floor(time / span)) != 0])
    same = np.diff(log.segment_runs()[rows]) == 0
    dm, di = np.diff(measured[rows])[same], np.diff(ideal[rows])[same]
    size = float(np.max(np.abs(di), initial=0.0))
    if not 0.0 < size < np.inf:
        return 1.0
    di = di / size  # any track width: the squares neither overflow nor underflow
    return float(dm @ di) / float(di @ di) / size


def yaw_scale_from_positions(
    log: WheelLog,
    time: np.ndarray,
    track_width: float,
    fixes: Fixes,
    scales: tuple[float, float],
) -> float:
    """Return the ideal yaw's scale that best explains the positions (grid, then parabola).

    The grid spans ``scales`` (low, high) in steps of 0.05.
    """
    if fixes.t.size == 0:
        return 1.0
    ideal = ideal_yaw(log, time, track_width)
    low, high = scales
    grid = np.arange(low, high + 1e-9, 0.05)
    costs = np.array(
        [fit_windows(wheel_track(log, time, k * ideal), fixes, 0.0, lever=False).cost for k in grid]
    )
    i = int(np.clip(np.argmin(costs), 1, grid.size - 2))
    den = costs[i - 1] - 2.0 * costs[i] + costs[i + 1]
    step = 0.5 * 0.05 * (costs[i - 1] - costs[i + 1]) / den if den > 0 else 0.0
    return float(grid[i] + np.clip(step, -0.05, 0.05))
