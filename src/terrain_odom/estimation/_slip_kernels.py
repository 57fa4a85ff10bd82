"""Steps of the slip EKF, compiled by numba (cached on disk) like the ICR EKF's.

The slip EKF (:class:`~terrain_odom.estimation.slip_ekf.SlipEkf`) spent
~300 us a log row in numpy's per-call overhead on tiny arrays: features,
ICRs, twist, arc and composition for the dead reckoning of every row, and at
every pose update the windowed pose change with its parameter Jacobian,
three times (Gauss-Newton), then filterpy's Joseph-form update. These
kernels do the same arithmetic in scalar loops:

- :func:`slip_predict`: ``P += Q dt`` (the random walk of the parameters);
- :func:`dead_reckon`: one wheel sample of dead reckoning with the current
  parameters, in place;
- :func:`slip_update`: the iterated update of a pose change (or of two
  chords, a GPS alone), with the robust noise inflation and the final
  filterpy-form step (Joseph form), in place;
- :func:`slip_estimate`: a log row's state (pose, ICRs at the held speeds,
  parameters) and standard deviations.

A wheel sample is the ICR EKF's process step
(:func:`~terrain_odom.estimation._kernels.step_jacobian`) with the ICRs of
the slip model at that sample's speeds; its Jacobian's ICR columns, chained
through the composition to the window's end and through the (unclipped)
ICR functions, give ``d change / d params``. The numpy formulation
(:class:`~terrain_odom.estimation.slip_ekf_reference.FilterpySlipEkf`,
:meth:`~terrain_odom.kinematics.slip.SlipModel.pose_change_with_jacobian`)
is the reference the tests hold these to (1e-12).

The kernels join the switch of :mod:`~terrain_odom.estimation._kernel_switch`
(:func:`~terrain_odom.estimation._kernel_switch.register`): the process's
first ``PURE_CALLS`` kernel calls run as Python, then all are compiled
together. The gain, the Joseph form and the other Kalman arithmetic are the
ICR EKF's (:mod:`~terrain_odom.estimation._kalman_kernels`). numba's disk
cache keys a function on its own file only: after editing a kernel of
``_kernels.py`` or ``_kalman_kernels.py`` that these call, touch this file
too (or clear ``__pycache__``), or the cache keeps the former callee
compiled in.

The model constants ``model`` are, in order: nominal track width ``B``,
curvature regulariser ``eps``, lateral acceleration on (1) or off (0),
curvature on or off, ``half_width_min, half_width_max, x_icr_max,
alpha_min, alpha_max`` (:func:`~terrain_odom.estimation.slip_ekf.model_constants`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from terrain_odom.estimation import _kalman_kernels as kalman
from terrain_odom.estimation import _kernels as icr
from terrain_odom.estimation._kalman_kernels import (
    inverse,
    joseph,
    kalman_gain,
    std_into,
    symmetrise,
    wrap,
)
from terrain_odom.estimation._kernel_switch import register
from terrain_odom.estimation._kernels import step_jacobian

__all__ = [
    "CHI2_99",
    "KERNELS",
    "dead_reckon",
    "slip_estimate",
    "slip_predict",
    "slip_update",
]

CHI2_99 = np.array([np.nan, 6.635, 9.210, 11.345])
"""99 % quantiles of the chi-square distribution with 1, 2 and 3 degrees of freedom."""


def _features(v_l: float, v_r: float, model: np.ndarray) -> tuple[float, float]:
    """Lateral acceleration ``a`` and curvature ``k`` (0 where switched off)."""
    diff = v_r - v_l
    a = abs(0.5 * (v_l + v_r) * diff / model[0])
    k = abs(diff) / (abs(v_l) + abs(v_r) + model[1])
    return a * model[2], k * model[3]


def _clip(value: float, lo: float, hi: float) -> float:
    """``min(max(value, lo), hi)``, as ``np.minimum(np.maximum(...))``."""
    return min(max(value, lo), hi)


def _icrs(
    x: np.ndarray, a: float, k: float, model: np.ndarray
) -> tuple[float, float, float, float]:
    """Clipped ``y_l, y_r, x_icr, alpha`` of the parameters ``x`` at features ``a, k``."""
    half = 0.5 * model[0]
    alpha = x[6] if x.shape[0] > 6 else 1.0
    return (
        _clip(half + x[0] * a + x[1] * k, model[4], model[5]),
        _clip(-(half + x[2] * a + x[3] * k), -model[5], -model[4]),
        _clip(x[4] * a + x[5] * k, -model[6], model[6]),
        _clip(alpha, model[7], model[8]),
    )


def _load_icrs(
    state: np.ndarray, x: np.ndarray, v_l: float, v_r: float, model: np.ndarray
) -> tuple[float, float]:
    """Write the ICRs at a sample into an ICR EKF state's ``y_l, y_r, x_icr, alpha``; return ``a, k``."""
    a, k = _features(v_l, v_r, model)
    state[3], state[4], state[5], state[6] = _icrs(x, a, k, model)
    return a, k


def _slip_predict(p: np.ndarray, q_density: np.ndarray, dt: float) -> None:
    """``P += diag(q_density) dt`` in place: the random walk of the parameters."""
    for i in range(p.shape[0]):
        p[i, i] += q_density[i] * dt


def _dead_reckon(
    pose: np.ndarray, x: np.ndarray, v_l: float, v_r: float, dt: float, model: np.ndarray
) -> None:
    """Advance ``pose`` in place over one wheel sample held ``dt`` s, parameters ``x``."""
    state = np.empty(7)  # the ICR EKF's: pose, y_l, y_r, x_icr, alpha
    state[:3] = pose
    _load_icrs(state, x, v_l, v_r, model)
    step_jacobian(state, v_l, v_r, dt, np.empty((7, 7)))
    pose[:] = state[:3]


def _pose_change(
    x: np.ndarray,
    v_l: np.ndarray,
    v_r: np.ndarray,
    dt: np.ndarray,
    lo: int,
    hi: int,
    model: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Pose change over samples ``lo .. hi - 1`` (start frame) and ``d change / d x``, (3, n).

    Each sample is a step of the ICR EKF's process model; the end pose's
    derivative by sample ``i``'s ICRs is the step's ICR columns moved to the
    end, ``[[1, 0, -(y_N - y_i+1)], [0, 1, x_N - x_i+1], [0, 0, 1]]`` times
    them, then through the ICR functions (``a, k`` per parameter pair).
    """
    n, count = x.shape[0], hi - lo
    state = np.zeros(7)  # the ICR EKF's: pose from the origin, the sample's ICRs
    after = np.empty((count, 2))  # x, y after each sample
    steps = np.empty((count, 3, 4))  # d pose after the step / d(y_l, y_r, x_icr, alpha)
    feats = np.empty((count, 2))
    jac = np.empty((7, 7))
    for i in range(count):
        feats[i, 0], feats[i, 1] = _load_icrs(state, x, v_l[lo + i], v_r[lo + i], model)
        step_jacobian(state, v_l[lo + i], v_r[lo + i], dt[lo + i], jac)
        steps[i] = jac[:3, 3:]
        after[i, 0], after[i, 1] = state[0], state[1]
    out = np.zeros((3, n))
    for i in range(count):
        a, k = feats[i, 0], feats[i, 1]
        shifts = (-(state[1] - after[i, 1]), state[0] - after[i, 0], 0.0)
        for row in range(3):
            g = steps[i, row]  # d end / d(y_l, y_r, x_icr, alpha)
            shift = shifts[row]
            g_l, g_r = g[0] + shift * steps[i, 2, 0], g[1] + shift * steps[i, 2, 1]
            g_x, g_alpha = g[2] + shift * steps[i, 2, 2], g[3] + shift * steps[i, 2, 3]
            out[row, 0] += g_l * a
            out[row, 1] += g_l * k
            out[row, 2] -= g_r * a
            out[row, 3] -= g_r * k
            out[row, 4] += g_x * a
            out[row, 5] += g_x * k
            if n > 6:
                out[row, 6] += g_alpha
    return state[:3].copy(), out


def _chord(change: np.ndarray, jac: np.ndarray, arm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Antenna displacement over a pose ``change`` and its Jacobian (as ``pose_measurement``)."""
    c, s = math.cos(change[2]), math.sin(change[2])
    chord = np.array(
        [change[0] + c * arm[0] - s * arm[1] - arm[0], change[1] + s * arm[0] + c * arm[1] - arm[1]]
    )
    d_x, d_y = -s * arm[0] - c * arm[1], c * arm[0] - s * arm[1]  # dR/dyaw @ arm
    out = np.empty((2, jac.shape[1]))
    for col in range(jac.shape[1]):
        out[0, col] = jac[0, col] + d_x * jac[2, col]
        out[1, col] = jac[1, col] + d_y * jac[2, col]
    return chord, out


def _chord_turn(
    first: np.ndarray,
    j_first: np.ndarray,
    second: np.ndarray,
    j_second: np.ndarray,
    arm: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Length of the second antenna chord and its turn from the first, with the Jacobian."""
    c1, j1 = _chord(first, j_first, arm)
    c2, j2 = _chord(second, j_second, arm)
    l1, l2 = c1[0] * c1[0] + c1[1] * c1[1], c2[0] * c2[0] + c2[1] * c2[1]
    length = math.sqrt(l2)
    h = np.array([length, wrap(first[2] + math.atan2(c2[1], c2[0]) - math.atan2(c1[1], c1[0]))])
    jac = np.empty((2, j_first.shape[1]))
    for col in range(j_first.shape[1]):
        jac[0, col] = (c2[0] * j2[0, col] + c2[1] * j2[1, col]) / length
        jac[1, col] = (
            j_first[2, col]
            + (c2[0] * j2[1, col] - c2[1] * j2[0, col]) / l2
            - (c1[0] * j1[1, col] - c1[1] * j1[0, col]) / l1
        )
    return h, jac


def _measure(
    x: np.ndarray,
    rows: np.ndarray,
    samples: np.ndarray,
    split: int,
    model: np.ndarray,
    antenna: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Return ``h(x)`` and ``dh/dx``: a pose change's ``rows`` (``split < 0``) or two chords.

    ``samples`` holds ``v_l, v_r, dt`` in rows; the chords split them at ``split``.
    """
    n, count = x.shape[0], samples.shape[1]
    v_l, v_r, dt = samples[0], samples[1], samples[2]
    if split >= 0:
        first, j_first = _pose_change(x, v_l, v_r, dt, 0, split, model)
        second, j_second = _pose_change(x, v_l, v_r, dt, split, count, model)
        return _chord_turn(first, j_first, second, j_second, antenna)
    change, full = _pose_change(x, v_l, v_r, dt, 0, count, model)
    m = rows.size
    h, jac = np.empty(m), np.empty((m, n))
    for j in range(m):
        h[j] = change[rows[j]]
        jac[j] = full[rows[j]]
    if m == 1 and n > 6:  # heading only: alpha not observable, held
        jac[0, 6] = 0.0
    return h, jac


def _residual(z: np.ndarray, h: np.ndarray, angle: int) -> np.ndarray:
    """``z - h``, row ``angle`` wrapped (none if negative)."""
    res = z - h
    if angle >= 0:
        res[angle] = wrap(res[angle])
    return res


def _inflation(res: np.ndarray, p: np.ndarray, jac: np.ndarray, r: np.ndarray) -> float:
    """Factor (>= 1) on ``R`` bringing the NIS ``res^T (H P H^T + R)^-1 res`` to the 99 % bound."""
    m = res.size
    s = _matmul_rect(_matmul_rect(jac, p), jac.T) + r
    si = inverse(s)
    nis = 0.0
    for i in range(m):
        for j in range(m):
            nis += res[i] * si[i, j] * res[j]
    return max(1.0, nis / CHI2_99[m])


def _matmul_rect(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Return ``a @ b`` of small matrices of any shapes, in loops."""
    out = np.zeros((a.shape[0], b.shape[1]))
    for i in range(a.shape[0]):
        for k in range(a.shape[1]):
            for j in range(b.shape[1]):
                out[i, j] += a[i, k] * b[k, j]
    return out


def _slip_update(
    x: np.ndarray,
    p: np.ndarray,
    z: np.ndarray,
    r: np.ndarray,
    samples: np.ndarray,
    split: int,
    model: np.ndarray,
    antenna: np.ndarray,
    iterations: int,
    robust: bool,
) -> tuple[float, bool]:
    """Fuse a measured pose change (``split < 0``) or two chords, in place; return the NIS.

    Gauss-Newton on the measurement from the prior ``x0, P`` (``iterations``
    times; with ``robust`` the first inflates ``R`` so that the NIS is at
    most its 99 % bound), then filterpy's update linearised at the last
    iterate: ``y = z - h - H (x0 - x_last)``, ``x = x0 + K y``, Joseph form;
    ``P`` symmetrised.

    Parameters
    ----------
    x, p : ndarray, shapes (n,), (n, n)
        Parameters ``l1 .. l6(, alpha)`` and covariance.
    z, r : ndarray, shapes (3,) or (2,)
        Measured ``dx, dy, dyaw`` (NaN where not measured) and variances; or,
        for chords, length (m) and turn (rad) with theirs.
    samples : ndarray, shape (3, K)
        ``v_l, v_r, dt`` of the wheel samples over the change (both chords).
    split : int
        Samples of the first chord; -1 for a pose change.
    model : ndarray, shape (9,)
        Model constants (see the module's docstring).
    antenna : ndarray, shape (2,)
        Position sensor in the robot frame (chords), m.
    iterations : int
        Gauss-Newton iterations (>= 1).
    robust : bool
        Inflate ``R`` for outliers.

    Returns
    -------
    nis : float
        Normalised innovation squared; NaN (nothing done) if nothing was measured.
    finite : bool
        Whether ``x`` and ``P`` are finite after the update.
    """
    if split >= 0:
        rows, angle = np.arange(2), 1
    else:
        rows = np.flatnonzero(np.isfinite(z))
        angle = -1 if rows.size == 0 or rows[-1] != 2 else rows.size - 1
    m = rows.size
    if m == 0:
        return math.nan, True
    z_m, r_m = np.empty(m), np.zeros((m, m))
    for j in range(m):
        z_m[j], r_m[j, j] = z[rows[j]], r[rows[j]]
    index = np.arange(m)
    x0 = x.copy()
    x_i = x0.copy()
    for it in range(iterations):
        h, jac = _measure(x_i, rows, samples, split, model, antenna)
        res = _residual(z_m, h, angle)
        if it == 0 and robust:
            r_m *= _inflation(res, p, jac, r_m)
        gain, si = kalman_gain(p, jac, index, r_m)
        x_last = x_i
        x_i = x0 + _matmul_vec(gain, res - _matmul_vec(jac, x0 - x_last))
    y = _residual(z_m, h + _matmul_vec(jac, x0 - x_last), angle)
    nis = 0.0
    for i in range(m):
        x[:] += gain[:, i] * y[i]
        for j in range(m):
            nis += y[i] * si[i, j] * y[j]
    joseph(p, gain, jac, index, r_m)
    symmetrise(p)
    return nis, bool(np.all(np.isfinite(x))) and bool(np.all(np.isfinite(p)))


def _matmul_vec(a: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Return ``a @ v`` of a small matrix and a vector, in loops."""
    out = np.zeros(a.shape[0])
    for i in range(a.shape[0]):
        for k in range(a.shape[1]):
            out[i] += a[i, k] * v[k]
    return out


def _slip_estimate(
    pose: np.ndarray, x: np.ndarray, p: np.ndarray, v_l: float, v_r: float, model: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Return a row's state ``pose, y_l, y_r, x_icr, params`` and its std (NaN for the pose).

    The ICRs' std is linearised through the unclipped ICR functions, as
    :meth:`~terrain_odom.estimation.slip_ekf.SlipEkf.icr_std`.
    """
    n = x.shape[0]
    a, k = _features(v_l, v_r, model)
    icrs = _icrs(x, a, k, model)
    state, std = np.empty(6 + n), np.empty(6 + n)
    for i in range(3):
        state[i], std[i] = pose[i], math.nan
        state[3 + i] = icrs[i]
        c = 2 * i  # the ICR's parameters: c (times a), c + 1 (times k)
        var = a * (a * p[c, c] + k * p[c + 1, c]) + k * (a * p[c, c + 1] + k * p[c + 1, c + 1])
        std[3 + i] = math.sqrt(max(var, 0.0))
    state[6:] = x
    std_into(p, std[6:])
    return state, std


_SHARED = ("wrap", "symmetrise", "inverse", "kalman_gain", "joseph", "std_into")
KERNELS: dict[str, Callable[..., Any]] = (
    {name: kalman.KERNELS[name] for name in _SHARED}
    | {"step_jacobian": icr.KERNELS["step_jacobian"]}
    | {
        name: globals()[name]
        for name in ("_features", "_clip", "_icrs", "_load_icrs", "_slip_predict", "_dead_reckon")
        + ("_pose_change", "_chord", "_chord_turn", "_measure", "_residual", "_inflation")
        + ("_matmul_rect", "_slip_update", "_matmul_vec", "_slip_estimate")
    }
)
"""These kernels as Python by name, with those of other modules they call (see :func:`register`)."""
_WRAPPERS = register(
    globals(), KERNELS, ("slip_predict", "dead_reckon", "slip_update", "slip_estimate")
)
slip_predict = _WRAPPERS["slip_predict"]
dead_reckon = _WRAPPERS["dead_reckon"]
slip_update = _WRAPPERS["slip_update"]
slip_estimate = _WRAPPERS["slip_estimate"]
