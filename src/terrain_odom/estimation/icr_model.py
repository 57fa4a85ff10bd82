"""The ICR EKF's state and process model (Chen et al. 2023, eq. 4-9).

State ``[x, y, yaw, y_l, y_r, x_icr]`` (m, m, rad, m, m, m), optionally
followed by the longitudinal slip factor ``alpha`` (dimensionless) that
multiplies both track surface speeds, and optionally by the heading
sensor's bias ``heading_bias`` (rad) (:func:`state_names`). The process
model is the ICR model (:func:`~terrain_odom.kinematics.twist_icr`)
integrated exactly over each wheel sample (constant twist, arc integration)
with the real ``dt``; the ICR parameters follow a random walk.

A consumer IMU's heading wanders slowly (tens of degrees over tens of
seconds) while its message claims a few degrees; fused as white noise, the
wander is absorbed as ICRs (``x_icr`` at its bound). With
:class:`HeadingBias` the heading measures ``yaw + heading_offset + b`` and
``b`` is a first-order Gauss-Markov process (``db = -b / tau dt + dw``,
stationary std ``sigma_b``, discretised exactly: ``b' = exp(-dt / tau) b``
plus noise of variance ``sigma_b**2 (1 - exp(-2 dt / tau))``; wrapped):
slow heading disagreements with the positions' course go to ``b``, the
heading's short-term changes still measure the turn rate.

The discrete Jacobian is ``F = d f_d / d X`` of the exact discrete step,
which reduces to ``I + dt * df/dX`` for small steps (the printed eq. 8
multiplies the whole block matrix by ``dt``; eq. 9 has the signs of
``dX/dyaw`` and ``dY/dyaw`` wrong). Tested against finite differences.
The filter over this model is :class:`~terrain_odom.estimation.icr_ekf.IcrEkf`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from terrain_odom.config import PoseSensorConfig
from terrain_odom.kinematics import (
    arc_increment_with_jacobian,
    twist_icr,
    twist_icr_jacobian,
    wrap_angle,
)

__all__ = [
    "BIAS_NAME",
    "STATE_NAMES",
    "HeadingBias",
    "icr_step",
    "icr_step_jacobian",
    "icr_step_with_jacobian",
    "state_names",
]

STATE_NAMES = ("x", "y", "yaw", "y_l", "y_r", "x_icr", "alpha")
BIAS_NAME = "heading_bias"
"""Name of the heading sensor's bias state, rad (last when estimated)."""
_YAW = 2


def state_names(estimate_alpha: bool, heading_bias: bool = False) -> tuple[str, ...]:
    """Names of the filter's states, in order; ``alpha`` then ``heading_bias`` when estimated."""
    names = STATE_NAMES if estimate_alpha else STATE_NAMES[:6]
    return (*names, BIAS_NAME) if heading_bias else names


class HeadingBias(NamedTuple):
    """The heading sensor's slow bias as a first-order Gauss-Markov state.

    Attributes
    ----------
    sigma : float
        Stationary standard deviation, rad (> 0).
    tau : float
        Time constant, s (finite, > 0).
    """

    sigma: float
    tau: float

    @classmethod
    def from_config(cls, sensor: PoseSensorConfig) -> HeadingBias | None:
        """Return the bias ``pose_sensor`` asks for (``heading_bias``), or None."""
        return cls(sensor.heading_wander, sensor.wander_time) if sensor.heading_bias else None


def _params(state: np.ndarray) -> tuple[float, float, float, float]:
    alpha = state[6] if state.shape[0] > 6 else 1.0
    return state[3], state[4], state[5], alpha


def icr_step_with_jacobian(
    state: ArrayLike, v_l: float, v_r: float, dt: float, tau: float | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Discrete process model over one wheel sample, and its Jacobian.

    The ICR model's twist is held for ``dt`` and integrated exactly (an arc);
    the parameters are unchanged. The Jacobian's pose rows are
    ``d pose' / d yaw = [-dY, dX, 1]`` (world displacement ``dX, dY`` of the
    step) and ``R(yaw) J_arc J_twist`` for the parameters; the parameter
    block is the identity.

    Parameters
    ----------
    state : array_like, shape (6,) to (8,)
        ``[x, y, yaw, y_l, y_r, x_icr(, alpha)(, b)]``.
    v_l, v_r : float
        Track surface speeds held over the step, m/s.
    dt : float
        Step duration, s.
    tau : float, optional
        Given: the last state is a heading bias ``b`` with this time
        constant, s (:class:`HeadingBias`): ``b' = exp(-dt / tau) b``
        (its noise is not part of the Jacobian).

    Returns
    -------
    state : ndarray, shape (n,)
        The predicted state, yaw wrapped.
    F : ndarray, shape (n, n)
        ``d state' / d state``.
    """
    s = np.asarray(state, dtype=float)
    if tau is not None:
        model, jac_model = icr_step_with_jacobian(s[:-1], v_l, v_r, dt)
        phi = math.exp(-dt / tau)
        jac = np.zeros((s.size, s.size))
        jac[:-1, :-1], jac[-1, -1] = jac_model, phi
        return np.append(model, phi * s[-1]), jac
    n = s.shape[0]
    params = _params(s)
    twist = twist_icr(v_l, v_r, *params)
    j_twist = twist_icr_jacobian(v_l, v_r, *params)[:, : n - 3]
    inc, j_arc = arc_increment_with_jacobian(*twist, dt)
    c, sn = np.cos(s[_YAW]), np.sin(s[_YAW])
    rot = np.array([[c, -sn], [sn, c]])
    world = rot @ inc[:2]
    out = s.copy()
    out[:2] += world
    out[_YAW] = wrap_angle(s[_YAW] + inc[2])
    jac = np.eye(n)
    jac[0, _YAW] = -world[1]
    jac[1, _YAW] = world[0]
    j_inc = j_arc @ j_twist  # d(dx, dy, dyaw) / d(params)
    jac[0:2, 3:] = rot @ j_inc[:2]
    jac[_YAW, 3:] = j_inc[2]
    return out, jac


def icr_step(state: ArrayLike, v_l: float, v_r: float, dt: float) -> np.ndarray:
    """Return the predicted state of :func:`icr_step_with_jacobian`."""
    return icr_step_with_jacobian(state, v_l, v_r, dt)[0]


def icr_step_jacobian(state: ArrayLike, v_l: float, v_r: float, dt: float) -> np.ndarray:
    """Return the Jacobian ``F`` of :func:`icr_step_with_jacobian`."""
    return icr_step_with_jacobian(state, v_l, v_r, dt)[1]
