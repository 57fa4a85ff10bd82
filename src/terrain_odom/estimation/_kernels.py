"""Steps of the ICR EKF, compiled by numba (cached on disk): one wheel sample in ~1 us.

The predict and update of :class:`~terrain_odom.estimation.icr_ekf.IcrEkf`
work in place on its state ``x`` (n,) and covariance ``P`` (n, n): the model's
``m`` = 6 or 7 states (pose, ICRs, ``alpha``), then optionally the heading
sensor's bias ``b`` (``bias`` holds its time constant and stationary
variance; empty: no bias state).
They are the filterpy formulation (``F P F^T + Q``; Joseph-form update with
the inverse of ``S``) written out in scalar loops, so a call costs what the
arithmetic costs instead of numpy's overhead on 7x7 arrays. The process model
repeats :func:`~terrain_odom.estimation.icr_model.icr_step_with_jacobian` term
by term; the tests compare both (and a filterpy filter) to 1e-12.

They run as Python for a process's first calls, then compiled (cached on
disk), under the switch of :mod:`~terrain_odom.estimation._kernel_switch`;
the Kalman arithmetic they share with the slip EKF's kernels
(:mod:`~terrain_odom.estimation._slip_kernels`) is in
:mod:`~terrain_odom.estimation._kalman_kernels`. The tests hold both modes
to the filterpy reference.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from terrain_odom.estimation import _kalman_kernels as kalman
from terrain_odom.estimation._kalman_kernels import (
    gain_from,
    innovation_covariance,
    joseph,
    std_into,
    symmetrise,
    wrap,
)
from terrain_odom.estimation._kernel_switch import register

__all__ = [
    "KERNELS",
    "REACQUIRED_NIS",
    "constrain",
    "icr_predict",
    "icr_rows",
    "icr_update",
    "std",
    "step_jacobian",
]

_SERIES_LIMIT = 1e-2  # as terrain_odom.kinematics.integration._SERIES_LIMIT
_FIRST_COUPLED = (2, 2, 3)  # pose row i of F: zero left of column _FIRST_COUPLED[i] but F[i, i] = 1
REACQUIRED_NIS = 10.0
"""A re-acquired component's NIS, in gate bounds, beyond which the pose variances grow."""


def _arc(phi: float) -> tuple[float, float, float, float]:
    """Return ``A, B, dA/dphi, dB/dphi`` of the arc integration (as ``_arc_coefficients``)."""
    if abs(phi) < _SERIES_LIMIT:
        p2 = phi * phi
        a = 1.0 - p2 / 6.0 + p2 * p2 / 120.0
        b = phi / 2.0 - phi * p2 / 24.0 + phi * p2 * p2 / 720.0
        return a, b, -phi / 3.0 + phi * p2 / 30.0, 0.5 - p2 / 8.0 + p2 * p2 / 144.0
    s, c = math.sin(phi), math.cos(phi)
    return (
        s / phi,
        (1.0 - c) / phi,
        (phi * c - s) / (phi * phi),
        (phi * s - (1.0 - c)) / (phi * phi),
    )


def step_jacobian(x: np.ndarray, v_l: float, v_r: float, dt: float, jac: np.ndarray) -> None:
    """Advance ``x`` in place over one wheel sample; write ``F`` into ``jac`` (n, n)."""
    n = x.shape[0]
    y_l, y_r, x_icr = x[3], x[4], x[5]
    alpha = x[6] if n > 6 else 1.0
    d = y_l - y_r
    v_x = alpha * (v_r * y_l - v_l * y_r) / d
    omega = alpha * (v_r - v_l) / d
    v_y = -omega * x_icr
    # d(v_x, v_y, omega) / d(y_l, y_r, x_icr, alpha), rows 0..2
    jt = np.zeros((3, 4))
    jt[0, 0] = alpha * y_r * (v_l - v_r) / d**2
    jt[0, 1] = alpha * y_l * (v_r - v_l) / d**2
    jt[0, 3] = (v_r * y_l - v_l * y_r) / d
    jt[2, 0] = -omega / d
    jt[2, 1] = omega / d
    jt[2, 3] = (v_r - v_l) / d
    for k in range(4):
        jt[1, k] = -x_icr * jt[2, k]
    jt[1, 2] = -omega
    phi = omega * dt
    a, b, da, db = _arc(phi)
    inc_x = dt * (v_x * a - v_y * b)
    inc_y = dt * (v_x * b + v_y * a)
    ja = np.zeros((3, 3))  # d(dx, dy, dyaw) / d(v_x, v_y, omega)
    ja[0, 0], ja[0, 1], ja[0, 2] = dt * a, -dt * b, dt * dt * (v_x * da - v_y * db)
    ja[1, 0], ja[1, 1], ja[1, 2] = dt * b, dt * a, dt * dt * (v_x * db + v_y * da)
    ja[2, 2] = dt
    c, s = math.cos(x[2]), math.sin(x[2])
    world_x = c * inc_x - s * inc_y
    world_y = s * inc_x + c * inc_y
    jac[:, :] = 0.0
    for i in range(n):
        jac[i, i] = 1.0
    jac[0, 2] = -world_y
    jac[1, 2] = world_x
    for k in range(n - 3):
        j0 = ja[0, 0] * jt[0, k] + ja[0, 1] * jt[1, k] + ja[0, 2] * jt[2, k]
        j1 = ja[1, 0] * jt[0, k] + ja[1, 1] * jt[1, k] + ja[1, 2] * jt[2, k]
        jac[0, 3 + k] = c * j0 - s * j1
        jac[1, 3 + k] = s * j0 + c * j1
        jac[2, 3 + k] = ja[2, 2] * jt[2, k]
    x[0] += world_x
    x[1] += world_y
    x[2] = wrap(x[2] + phi)


def _icr_predict(
    x: np.ndarray,
    p: np.ndarray,
    q_density: np.ndarray,
    v_l: float,
    v_r: float,
    dt: float,
    bias: np.ndarray,
) -> None:
    """Predict over one wheel sample in place: the ICR step, ``P = F P F^T + Q dt``, symmetrised.

    A heading bias ``b`` (the last state, with ``bias``) is a first-order
    Gauss-Markov process discretised exactly: ``b' = phi b``, ``phi =
    exp(-dt / tau)``, so its row and column of ``F`` are ``phi`` on the
    diagonal, zero elsewhere, and its noise variance over the step is
    ``sigma_b**2 (1 - phi**2)`` (its entry of ``q_density`` is 0).

    Parameters
    ----------
    x : ndarray, shape (n,)
        State ``x, y, yaw, y_l, y_r, x_icr(, alpha)(, b)``; ``y_l > y_r``.
    p : ndarray, shape (n, n)
        Covariance.
    q_density : ndarray, shape (n,)
        Process noise density (variance per second).
    v_l, v_r : float
        Track speeds held over the step, m/s.
    dt : float
        Step, s.
    bias : ndarray, shape (0,) or (2,)
        Time constant ``tau`` (s) and stationary variance ``sigma_b**2``
        (rad^2) of the heading bias; empty: no bias state.
    """
    n = x.shape[0]
    m = n - 1 if bias.size else n  # the model's states
    jac = np.empty((n, n))
    phi = 1.0
    if m == n:
        step_jacobian(x, v_l, v_r, dt, jac)
    else:  # the model's block; the bias column of the pose rows is zero
        jac[:, :] = 0.0
        step_jacobian(x[:m], v_l, v_r, dt, jac[:m, :m])
        phi = math.exp(-dt / bias[0])
        x[m] *= phi
    # F is the identity but in its pose rows (F[0, 2], F[1, 2], F[:3, 3:]; see step_jacobian)
    # and a bias's diagonal, phi (its row of F P and column of F^T scaled below):
    # F P F^T changes only the pose rows, then the pose columns. The sums take the full
    # products' terms in their order without the exact zeros: the same bits, ~2.5x fewer terms.
    fp = p.copy()  # F P
    for i in range(3):
        for j in range(n):
            acc = p[i, j]
            for k in range(_FIRST_COUPLED[i], n):
                acc += jac[i, k] * p[k, j]
            fp[i, j] = acc
    if m < n:  # the bias row of F P
        for j in range(n):
            fp[m, j] *= phi
    for i in range(n):  # (F P) F^T
        for j in range(n):
            acc = fp[i, j]
            if j < 3:
                for k in range(_FIRST_COUPLED[j], n):
                    acc += fp[i, k] * jac[j, k]
            elif j >= m:  # the bias column of F^T
                acc *= phi
            p[i, j] = acc
        p[i, i] += q_density[i] * dt
    if m < n:
        p[m, m] += bias[1] * -math.expm1(-2.0 * dt / bias[0])
    symmetrise(p)


def _sensor(
    x: np.ndarray, rows: np.ndarray, mounting: np.ndarray, biased: bool
) -> tuple[np.ndarray, np.ndarray]:
    """Return ``h`` and ``H`` of :func:`~terrain_odom.estimation.pose_measurement.measurement`.

    With ``biased``, the heading also measures the last state, the bias ``b``:
    ``wrap(yaw + offset + b)``, ``d h / d b = 1``.
    """
    n, m = x.shape[0], rows.size
    arm_x, arm_y, offset = mounting[0], mounting[1], mounting[2]
    c, s = math.cos(x[2]), math.sin(x[2])
    full_h = np.array([x[0] + (c * arm_x - s * arm_y), x[1] + (s * arm_x + c * arm_y), 0.0])
    full_h[2] = wrap(x[2] + offset + x[n - 1]) if biased else wrap(x[2] + offset)
    h, jac = np.empty(m), np.zeros((m, n))
    for i in range(m):
        row = rows[i]
        h[i] = full_h[row]
        jac[i, row] = 1.0
        if row == 2 and biased:
            jac[i, n - 1] = 1.0
        elif row == 0:
            jac[i, 2] = -s * arm_x - c * arm_y
        elif row == 1:
            jac[i, 2] = c * arm_x - s * arm_y
    return h, jac


def _icr_update(
    x: np.ndarray,
    p: np.ndarray,
    z: np.ndarray,
    r: np.ndarray,
    mounting: np.ndarray,
    limits: np.ndarray,
    gate: np.ndarray,
    gating: np.ndarray,
    t: float,
    bias: np.ndarray,
) -> tuple[float, bool]:
    """Fuse the measured components of a pose row in place; return the NIS.

    filterpy's Joseph-form update with the pose sensors' measurement (the
    antenna position ``x, y`` as a pair, the heading; ``h`` and ``H`` at the
    prior state, heading innovation wrapped), after a chi-square gate
    (:func:`_gate`) that may reject the position or the heading. A heading
    fused without a position leaves ``alpha`` alone: its gain row is zero (a
    Schmidt update; ``P`` through the Joseph form, which holds for any gain).
    Then the state is constrained: yaw wrapped, ``y_l`` in ``[lim0, lim1]``,
    ``y_r`` in ``[-lim1, -lim0]``, ``|x_icr| <= lim2``, ``alpha`` in
    ``[lim3, lim4]``; ``P`` symmetrised.

    Parameters
    ----------
    x, p : ndarray, shapes (n,), (n, n)
        State and covariance.
    z : ndarray, shape (3,)
        Measured antenna ``x, y`` and heading; NaN where not measured (``x``
        without ``y`` is left out).
    r : ndarray, shape (3, 3)
        Measurement noise covariance.
    mounting : ndarray, shape (3,)
        ``antenna_x, antenna_y, heading_offset``.
    limits : ndarray, shape (5,)
        ``half_width_min, half_width_max, x_icr_max, alpha_min, alpha_max``.
    gate : ndarray, shape (4,)
        NIS bounds of a position and of a heading (inf: no gate), and after
        how many rejections in a row or how many seconds of them a
        component is re-acquired.
    gating : ndarray, shape (8,)
        The gate's state, updated in place: time of the first of the current
        rejections of positions and of headings (NaN: none), their number,
        then the counts of rejected positions, headings, re-acquired
        positions, headings.
    t : float
        The filter's clock, s.
    bias : ndarray, shape (0,) or (2,)
        Non-empty: the last state is the heading's bias (see :func:`icr_predict`).

    Returns
    -------
    nis : float
        Normalised innovation squared of the components fused; NaN (and
        nothing done) if none was measured or all were rejected.
    finite : bool
        Whether ``x`` and ``P`` are finite after the update.
    """
    n = x.shape[0]
    pair = math.isfinite(z[0]) and math.isfinite(z[1])
    heading = math.isfinite(z[2])
    if not (pair or heading):
        return math.nan, True
    biased = bias.size > 0
    model = n - 1 if biased else n
    rows = _rows(pair, heading)
    h, jac = _sensor(x, rows, mounting, biased)
    y = _innovation(z, h, rows)
    pht, s = innovation_covariance(p, jac, rows, r)
    fuse_pair, fuse_heading, grown = _gate(p, y, s, pair, heading, gate, gating, t)
    if not (fuse_pair or fuse_heading):
        return math.nan, True
    if grown or fuse_pair != pair or fuse_heading != heading:
        pair = fuse_pair
        rows = _rows(pair, fuse_heading)
        h, jac = _sensor(x, rows, mounting, biased)
        y = _innovation(z, h, rows)
        pht, s = innovation_covariance(p, jac, rows, r)
    m = rows.size
    k_gain, si = gain_from(pht, s)
    if model > 6 and not pair:  # heading only: alpha not observable, held (Schmidt)
        k_gain[6, :] = 0.0
    for i in range(n):
        for j in range(m):
            x[i] += k_gain[i, j] * y[j]
    nis = 0.0
    for i in range(m):
        for j in range(m):
            nis += y[i] * si[i, j] * y[j]
    joseph(p, k_gain, jac, rows, r)
    return nis, _constrain(x, p, limits, model)


def _rows(pair: bool, heading: bool) -> np.ndarray:
    """Return the measured rows of ``x, y, yaw``: the position pair, the heading."""
    return np.flatnonzero(np.array([pair, pair, heading]))


def _innovation(z: np.ndarray, h: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Return ``z[rows] - h``, the heading's wrapped."""
    m = rows.size
    y = np.empty(m)
    for j in range(m):
        y[j] = z[rows[j]] - h[j]
        if rows[j] == 2:
            y[j] = wrap(y[j])
    return y


def _gate(
    p: np.ndarray,
    y: np.ndarray,
    s: np.ndarray,
    pair: bool,
    heading: bool,
    gate: np.ndarray,
    gating: np.ndarray,
    t: float,
) -> tuple[bool, bool, bool]:
    """Decide which measured components to fuse: the chi-square gate with re-acquisition.

    The position's NIS (its 2x2 block of ``S``, 2 degrees of freedom) and the
    heading's (its variance in ``S``, 1) are each held to their bound
    ``gate[0]``, ``gate[1]``. A component beyond it is rejected, unless
    ``gate[2]`` components of its kind in a row, or all for ``gate[3]``
    seconds, were rejected before it: then it is fused, the pose variances
    it measures first grown (``P`` in place) in proportion to its NIS beyond
    :data:`REACQUIRED_NIS` times the bound, so a filter that is truly off
    (after an outage, a reset) snaps back to the measurement without its
    ICRs taking the blame, while an innovation a few times the bound (a
    sudden change of terrain) teaches the ICRs as usual. A lone jump is
    rejected. ``gating`` (see :func:`icr_update`) keeps the time and number
    of the current rejections of each kind, and the counts.

    Returns
    -------
    pair, heading : bool
        Whether the position and the heading are to be fused.
    grown : bool
        Whether ``P`` was changed (``S`` must be computed again).
    """
    fuse = [pair, heading]
    grown = False
    last = y.size - 1
    for g in range(2):
        if not fuse[g]:
            continue
        if g == 0:
            det = s[0, 0] * s[1, 1] - s[0, 1] * s[1, 0]
            nis = (
                y[0] * (s[1, 1] * y[0] - s[0, 1] * y[1]) + y[1] * (s[0, 0] * y[1] - s[1, 0] * y[0])
            ) / det
        else:
            nis = y[last] * y[last] / s[last, last]
        if not nis > gate[g]:  # within the bound (NaN: the update finds it non-finite)
            gating[g], gating[2 + g] = math.nan, 0.0
            continue
        if math.isnan(gating[g]):
            gating[g] = t
        if gating[2 + g] < gate[2] and t - gating[g] < gate[3]:
            fuse[g] = False
            gating[2 + g] += 1.0
            gating[4 + g] += 1.0
            continue
        gating[g], gating[2 + g] = math.nan, 0.0  # re-acquired: the pose variances absorb it
        gating[6 + g] += 1.0
        grown = True
        grow = max(nis / (REACQUIRED_NIS * gate[g]) - 1.0, 0.0)
        if g == 0:
            p[0, 0] += grow * s[0, 0]
            p[1, 1] += grow * s[1, 1]
        else:
            p[2, 2] += grow * s[last, last]
    return fuse[0], fuse[1], grown


def _constrain(x: np.ndarray, p: np.ndarray, limits: np.ndarray, model: int) -> bool:
    """Wrap yaw, clip the ICR state into ``limits`` (see :func:`icr_update`), symmetrise ``P``.

    ``model`` is the number of the model's states (6, or 7 with ``alpha``);
    a heading bias after them is an angle, wrapped like the yaw.

    Returns
    -------
    bool
        Whether ``x`` and ``P`` are all finite.
    """
    x[2] = wrap(x[2])
    x[3] = min(max(x[3], limits[0]), limits[1])
    x[4] = min(max(x[4], -limits[1]), -limits[0])
    x[5] = min(max(x[5], -limits[2]), limits[2])
    if model > 6:
        x[6] = min(max(x[6], limits[3]), limits[4])
    if x.shape[0] > model:
        x[model] = wrap(x[model])
    symmetrise(p)
    return bool(np.all(np.isfinite(x))) and bool(np.all(np.isfinite(p)))


def _std(p: np.ndarray) -> np.ndarray:
    """Return the standard deviations ``sqrt(max(diag(P), 0))``, shape (n,)."""
    out = np.empty(p.shape[0])
    std_into(p, out)
    return out


def _icr_rows(
    x: np.ndarray,
    p: np.ndarray,
    noise: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    rows: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    held: np.ndarray,
    gating: np.ndarray,
    states: np.ndarray,
    stds: np.ndarray,
) -> tuple[int, float, int]:
    """Run log rows through the filter in place: per row a predict, an update, the estimate.

    Row ``i`` predicts from the previous row's time with the speeds held
    since (:func:`icr_predict`), holds its own speeds, fuses its pose
    components if it has any (:func:`icr_update`), then writes the state and
    its standard deviations into ``states[i]`` and ``stds[i]``: what
    :meth:`~terrain_odom.estimation.online.OnlineOdometry.wheels`,
    :meth:`~terrain_odom.estimation.online.OnlineOdometry.pose` and
    :meth:`~terrain_odom.estimation.online.OnlineOdometry.estimate` do per
    row on an anchored filter, in one call.

    Parameters
    ----------
    x, p : ndarray, shapes (n,), (n, n)
        State and covariance.
    noise : tuple of ndarray
        ``q_density`` (n,), ``r`` (3, 3), ``mounting`` (3,), ``limits`` (5,),
        ``gate`` (4,), ``bias`` (0 or 2,) as for :func:`icr_predict` and
        :func:`icr_update`.
    rows : tuple of ndarray
        ``t`` (B,), s, increasing; ``v_l``, ``v_r`` (B,), m/s; ``z`` (B, 3),
        the measured pose (NaN where not measured).
    held : ndarray, shape (4,)
        ``t, v_l, v_r`` of the previous wheel sample and the filter's clock
        (its sum of steps, s); advanced in place to the last row.
    gating : ndarray, shape (8,)
        The gate's state and counts (see :func:`icr_update`), in place.
    states, stds : ndarray, shape (B, n)
        Filled with the estimate after each row.

    Returns
    -------
    updates : int
        Rows whose pose updated the filter (a component passed the gate).
    nis : float
        Normalised innovation squared of the last update (NaN if none).
    bad : int
        The row after which the state was not finite (the rows after it are
        not run), or -1.
    """
    q_density, r, mounting, limits, gate, bias = noise
    t, v_l, v_r, z = rows
    updates, last_nis = 0, math.nan
    for i in range(t.shape[0]):
        dt = t[i] - held[0]
        _icr_predict(x, p, q_density, held[1], held[2], dt, bias)
        held[3] += dt
        held[0], held[1], held[2] = t[i], v_l[i], v_r[i]
        nis, finite = _icr_update(x, p, z[i], r, mounting, limits, gate, gating, held[3], bias)
        if not finite:
            return updates, last_nis, i
        if not math.isnan(nis):
            updates += 1
            last_nis = nis
        states[i, :] = x
        std_into(p, stds[i])
    return updates, last_nis, -1


def _row_calls(*args: Any) -> int:
    """Count a call of :func:`icr_rows` as two calls per row (a predict and an update)."""
    return 2 * len(args[3][0])


_SHARED = ("wrap", "symmetrise", "innovation_covariance", "gain_from", "joseph", "std_into")
KERNELS: dict[str, Callable[..., Any]] = {name: kalman.KERNELS[name] for name in _SHARED} | {
    name: globals()[name]
    for name in ("_arc", "step_jacobian", "_sensor", "_rows", "_innovation", "_gate")
    + ("_icr_predict", "_icr_update", "_constrain", "_std", "_icr_rows")
}
"""These kernels as Python by name, with those of other modules they call (see :func:`register`)."""
_PUBLIC = ("icr_predict", "icr_update", "constrain", "std", "icr_rows")
_WRAPPERS = register(globals(), KERNELS, _PUBLIC, {"icr_rows": _row_calls})
icr_predict = _WRAPPERS["icr_predict"]
icr_update = _WRAPPERS["icr_update"]
icr_rows = _WRAPPERS["icr_rows"]
constrain = _WRAPPERS["constrain"]
std = _WRAPPERS["std"]
