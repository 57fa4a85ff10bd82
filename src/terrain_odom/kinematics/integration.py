"""Planar pose integration that is exact for a constant body twist.

A body twist ``(v_x, v_y, omega)`` held for ``dt`` seconds moves the robot
along a circular arc. In the frame of the start pose the increment is

.. math::

    \\Delta x = dt\\,(v_x A(\\varphi) - v_y B(\\varphi)),\\quad
    \\Delta y = dt\\,(v_x B(\\varphi) + v_y A(\\varphi)),\\quad
    \\Delta\\theta = \\varphi = \\omega\\,dt,

with :math:`A(\\varphi) = \\sin\\varphi/\\varphi` and
:math:`B(\\varphi) = (1-\\cos\\varphi)/\\varphi` (series near zero, so
straight-line motion is exact too). Poses are ``(x, y, yaw)`` arrays with the
package convention: x forward, y left, yaw counter-clockwise, wrapped to
(-pi, pi].
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "wrap_angle",
    "arc_increment",
    "arc_increment_jacobian",
    "arc_increment_with_jacobian",
    "compose",
    "relative_pose",
    "integrate",
]

_SERIES_LIMIT = 1e-2  # |phi| below which the Taylor series is used (error < 1e-12)


def wrap_angle(angle: ArrayLike) -> np.ndarray:
    """Wrap angles to (-pi, pi].

    Angles already inside the interval are returned bit-exact; NaN stays NaN.

    Parameters
    ----------
    angle : array_like
        Angles, rad.

    Returns
    -------
    ndarray
        The same angles in (-pi, pi].

    Examples
    --------
    >>> wrap_angle([np.pi, -np.pi, 3 * np.pi / 2]).round(4).tolist()
    [3.1416, 3.1416, -1.5708]
    """
    a = np.asarray(angle, dtype=float)
    inside = (a > -np.pi) & (a <= np.pi)
    return np.where(inside, a, np.pi - np.mod(np.pi - a, 2.0 * np.pi))


def _arc_coefficients(phi: np.ndarray, derivatives: bool = True) -> tuple[np.ndarray, ...]:
    """Return ``A, B`` (and ``dA/dphi, dB/dphi`` if ``derivatives``) for angles ``phi`` (rad).

    The closed forms where ``|phi| >= _SERIES_LIMIT``, the Taylor series
    elsewhere, each computed only on its own angles (at 20 Hz most steps are
    small), with each sine and cosine taken once.
    """
    phi = np.asarray(phi, dtype=float)
    small = np.abs(phi) < _SERIES_LIMIT
    if small.all():
        return _arc_series(phi, derivatives)
    if not small.any():
        return _arc_closed(phi, derivatives)
    out = tuple(np.empty_like(phi) for _ in range(4 if derivatives else 2))
    for branch, where in ((_arc_series, small), (_arc_closed, ~small)):
        for value, part in zip(out, branch(phi[where], derivatives), strict=True):
            value[where] = part
    return out


def _arc_series(phi: np.ndarray, derivatives: bool) -> tuple[np.ndarray, ...]:
    """Return the Taylor series of :func:`_arc_coefficients` (error < 1e-12 for ``|phi| < 1e-2``)."""
    p2 = phi * phi
    a = 1.0 - p2 / 6.0 + p2 * p2 / 120.0
    b = phi / 2.0 - phi * p2 / 24.0 + phi * p2 * p2 / 720.0
    if not derivatives:
        return a, b
    return a, b, -phi / 3.0 + phi * p2 / 30.0, 0.5 - p2 / 8.0 + p2 * p2 / 144.0


def _arc_closed(phi: np.ndarray, derivatives: bool) -> tuple[np.ndarray, ...]:
    """Return the closed forms of :func:`_arc_coefficients` (``phi`` away from 0)."""
    sin, cos = np.sin(phi), np.cos(phi)
    one_minus_cos = 1.0 - cos
    a, b = sin / phi, one_minus_cos / phi
    if not derivatives:
        return a, b
    p2 = phi * phi
    return a, b, (phi * cos - sin) / p2, (phi * sin - one_minus_cos) / p2


def arc_increment(v_x: ArrayLike, v_y: ArrayLike, omega: ArrayLike, dt: ArrayLike) -> np.ndarray:
    """Pose increment of a constant twist held for ``dt``, in the start frame.

    Parameters
    ----------
    v_x, v_y : array_like
        Body-frame forward and leftward speed, m/s.
    omega : array_like
        Yaw rate, rad/s, counter-clockwise positive.
    dt : array_like
        Duration, s (0 gives a zero increment). All inputs broadcast.

    Returns
    -------
    ndarray, shape (..., 3)
        ``(dx, dy, dyaw)`` in the frame of the start pose (m, m, rad; the
        angle is not wrapped).

    Examples
    --------
    Half a turn on a circle of radius 1 m ends 2 m to the left:

    >>> arc_increment(np.pi, 0.0, np.pi, 1.0).round(6).tolist()
    [0.0, 2.0, 3.141593]
    """
    return np.stack(_arc_parts(v_x, v_y, omega, dt), axis=-1)


def _arc_parts(
    v_x: ArrayLike, v_y: ArrayLike, omega: ArrayLike, dt: ArrayLike
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return the ``dx, dy, dyaw`` of :func:`arc_increment` as three contiguous arrays."""
    v_x, v_y, omega, dt = np.broadcast_arrays(
        *(np.asarray(a, dtype=float) for a in (v_x, v_y, omega, dt))
    )
    phi = omega * dt
    a, b = _arc_coefficients(phi, derivatives=False)
    return dt * (v_x * a - v_y * b), dt * (v_x * b + v_y * a), phi


def arc_increment_with_jacobian(
    v_x: ArrayLike, v_y: ArrayLike, omega: ArrayLike, dt: ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`arc_increment` and its Jacobian with respect to the twist, at once.

    Returns
    -------
    increment : ndarray, shape (..., 3)
        ``(dx, dy, dyaw)`` in the start frame.
    jacobian : ndarray, shape (..., 3, 3)
        ``d(dx, dy, dyaw) / d(v_x, v_y, omega)``.
    """
    v_x, v_y, omega, dt = np.broadcast_arrays(
        *(np.asarray(a, dtype=float) for a in (v_x, v_y, omega, dt))
    )
    phi = omega * dt
    a, b, da, db = _arc_coefficients(phi)
    inc = np.stack([dt * (v_x * a - v_y * b), dt * (v_x * b + v_y * a), phi], axis=-1)
    jac = np.zeros(v_x.shape + (3, 3))
    jac[..., 0, 0] = dt * a
    jac[..., 0, 1] = -dt * b
    jac[..., 0, 2] = dt * dt * (v_x * da - v_y * db)
    jac[..., 1, 0] = dt * b
    jac[..., 1, 1] = dt * a
    jac[..., 1, 2] = dt * dt * (v_x * db + v_y * da)
    jac[..., 2, 2] = dt
    return inc, jac


def arc_increment_jacobian(
    v_x: ArrayLike, v_y: ArrayLike, omega: ArrayLike, dt: ArrayLike
) -> np.ndarray:
    """Jacobian of :func:`arc_increment` with respect to the twist.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``d(dx, dy, dyaw) / d(v_x, v_y, omega)``.
    """
    return arc_increment_with_jacobian(v_x, v_y, omega, dt)[1]


def compose(pose: ArrayLike, increment: ArrayLike) -> np.ndarray:
    """Apply a start-frame increment to a pose (SE(2) composition).

    Parameters
    ----------
    pose : array_like, shape (..., 3)
        ``(x, y, yaw)`` in the world frame.
    increment : array_like, shape (..., 3)
        ``(dx, dy, dyaw)`` expressed in the frame of ``pose``.

    Returns
    -------
    ndarray, shape (..., 3)
        The resulting pose, yaw wrapped to (-pi, pi].
    """
    pose = np.asarray(pose, dtype=float)
    inc = np.asarray(increment, dtype=float)
    c, s = np.cos(pose[..., 2]), np.sin(pose[..., 2])
    x = pose[..., 0] + c * inc[..., 0] - s * inc[..., 1]
    y = pose[..., 1] + s * inc[..., 0] + c * inc[..., 1]
    return np.stack(np.broadcast_arrays(x, y, wrap_angle(pose[..., 2] + inc[..., 2])), axis=-1)


def relative_pose(pose_a: ArrayLike, pose_b: ArrayLike) -> np.ndarray:
    """Pose of ``b`` in the frame of ``a`` (``a^-1 * b``), yaw wrapped.

    Examples
    --------
    >>> relative_pose([1.0, 0.0, np.pi / 2], [1.0, 2.0, np.pi]).round(6).tolist()
    [2.0, 0.0, 1.570796]
    """
    a = np.asarray(pose_a, dtype=float)
    b = np.asarray(pose_b, dtype=float)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    dx, dy = b[..., 0] - a[..., 0], b[..., 1] - a[..., 1]
    return np.stack(
        np.broadcast_arrays(c * dx + s * dy, -s * dx + c * dy, wrap_angle(b[..., 2] - a[..., 2])),
        axis=-1,
    )


def integrate(
    v_x: ArrayLike,
    v_y: ArrayLike,
    omega: ArrayLike,
    dt: ArrayLike,
    *,
    start: ArrayLike | None = None,
) -> np.ndarray:
    """Integrate a sequence of constant-twist steps along the last axis.

    Vectorised over any leading axes, so many windows are integrated at once;
    pad ragged windows with ``dt = 0`` (a zero increment).

    Parameters
    ----------
    v_x, v_y, omega : array_like, shape (..., K)
        Body twist of each step (m/s, m/s, rad/s).
    dt : array_like, shape (..., K)
        Duration of each step, s.
    start : array_like, shape (..., 3), optional
        Start pose; the origin if omitted.

    Returns
    -------
    ndarray, shape (..., K + 1, 3)
        Pose before the first step and after each step, yaw wrapped.

    Examples
    --------
    Four quarter turns of a unit circle come back to the start:

    >>> poses = integrate([np.pi / 2] * 4, [0.0] * 4, [np.pi / 2] * 4, [1.0] * 4)
    >>> np.abs(poses[-1]).max() < 1e-12
    np.True_
    """
    inc_x, inc_y, inc_yaw = _arc_parts(v_x, v_y, omega, dt)  # each (..., K), in the start frame
    lead = inc_yaw.shape[:-1]
    start_pose = (
        np.zeros(lead + (3,))
        if start is None
        else np.broadcast_to(np.asarray(start, dtype=float), lead + (3,))
    )
    # Heading before each step, then rotate each body increment into the world.
    yaw = start_pose[..., None, 2] + np.concatenate(
        [np.zeros(lead + (1,)), np.cumsum(inc_yaw, axis=-1)], axis=-1
    )
    c, s = np.cos(yaw[..., :-1]), np.sin(yaw[..., :-1])
    dx = c * inc_x - s * inc_y
    dy = s * inc_x + c * inc_y
    zero = np.zeros(lead + (1,))
    x = start_pose[..., None, 0] + np.concatenate([zero, np.cumsum(dx, axis=-1)], axis=-1)
    y = start_pose[..., None, 1] + np.concatenate([zero, np.cumsum(dy, axis=-1)], axis=-1)
    return np.stack([x, y, wrap_angle(yaw)], axis=-1)
