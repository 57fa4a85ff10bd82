"""Skid-steer kinematic models: body twist from left/right track surface speeds.

Every model maps track surface speeds ``v_l, v_r`` (m/s, forward positive;
``v = wheel_radius * omega`` for wheels) to the body twist
``(v_x, v_y, omega)``: forward speed, leftward speed (m/s) and yaw rate
(rad/s, counter-clockwise). Conventions: x forward, y left, z up.

ICR convention. ``y_l`` and ``y_r`` are the lateral (y) coordinates of the
left and right track instantaneous centres of rotation (``y_l > 0 > y_r`` for
a normal vehicle), ``x_icr`` is the coordinate of the ICRs along the forward
axis, so the lateral body speed is ``v_y = -omega * x_icr``. Chen et al. 2023
call it ``x_G`` with the opposite sign (``x_icr = -x_G``); Martinez et al.
2004 use a frame with Y forward and X to the right, so ``x_ICRl = -y_l``,
``x_ICRr = -y_r`` and ``y_ICR = x_icr``. Converters are given below.

All functions broadcast: speeds of shape ``(N,)`` with parameters of shape
``(P, 1)`` evaluate ``P`` parameter sets at once (used by the optimisers).

References
----------
.. [1] Baril et al., "Evaluation of Skid-Steering Kinematic Models for
   Subarctic Environments", CRV 2020, eq. 3, 7-12.
.. [2] Chen et al., "Kinematics Model Estimation of 4W Skid-Steering Mobile
   Robots Using Visual Terrain Classification", J. Robotics 2023, eq. 3.
.. [3] Martinez et al., "Kinematic Modelling of Tracked Vehicles by
   Experimental Identification", IROS 2004, eq. 7-9, 12-13.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "KinematicModel",
    "MODELS",
    "get_model",
    "twist_idd",
    "twist_edd_sym",
    "twist_edd_asym",
    "twist_roc",
    "twist_linear",
    "twist_icr",
    "twist_icr_jacobian",
    "steering_efficiency",
    "eccentricity",
    "icr_from_chen",
    "icr_from_martinez",
    "icr_to_martinez",
]

Twist = tuple[np.ndarray, np.ndarray, np.ndarray]


def _as_float(*arrays: ArrayLike) -> list[np.ndarray]:
    return [np.asarray(a, dtype=float) for a in arrays]


def _twist(v_x: ArrayLike, v_y: ArrayLike, omega: ArrayLike) -> Twist:
    """Return the twist components broadcast to one common shape."""
    v_x, v_y, omega = np.broadcast_arrays(*_as_float(v_x, v_y, omega))
    return v_x.copy(), v_y.copy(), omega.copy()


def _check_icr_spacing(y_l: np.ndarray, y_r: np.ndarray) -> None:
    if np.any(~(y_l - y_r > 0.0)):
        raise ValueError(
            f"ICR model needs y_l > y_r (left track ICR to the left of the right one); "
            f"got y_l={np.asarray(y_l).ravel()[:3]}, y_r={np.asarray(y_r).ravel()[:3]}"
        )


def twist_idd(v_l: ArrayLike, v_r: ArrayLike, track_width: ArrayLike) -> Twist:
    """Ideal differential drive (Baril eq. 3).

    Parameters
    ----------
    v_l, v_r : array_like
        Track surface speeds, m/s.
    track_width : array_like
        Track width ``B``, m (> 0).

    Returns
    -------
    v_x, v_y, omega : ndarray
        Body twist (m/s, m/s, rad/s); ``v_y`` is zero.

    Examples
    --------
    >>> [a.tolist() for a in twist_idd([0.5, 1.0], [1.5, 1.0], 0.5)]
    [[1.0, 1.0], [0.0, 0.0], [2.0, 0.0]]
    """
    v_l, v_r, b = _as_float(v_l, v_r, track_width)
    if np.any(~(b > 0.0)):
        raise ValueError(f"track_width must be > 0 m, got {b}")
    v_x = 0.5 * (v_l + v_r)
    omega = (v_r - v_l) / b
    return _twist(v_x, 0.0, omega)


def twist_edd_sym(v_l: ArrayLike, v_r: ArrayLike, alpha: ArrayLike, b_hat: ArrayLike) -> Twist:
    """Symmetric extended differential drive (Baril eq. 8-9).

    Parameters
    ----------
    v_l, v_r : array_like
        Track surface speeds, m/s.
    alpha : array_like
        Longitudinal slip factor (1 = no slip), dimensionless.
    b_hat : array_like
        Effective track width, m (> 0).

    Returns
    -------
    v_x, v_y, omega : ndarray
        Body twist (m/s, m/s, rad/s).
    """
    v_l, v_r, alpha, b_hat = _as_float(v_l, v_r, alpha, b_hat)
    v_x, v_y, omega = twist_idd(v_l, v_r, b_hat)
    return _twist(alpha * v_x, v_y, alpha * omega)


def twist_edd_asym(
    v_l: ArrayLike,
    v_r: ArrayLike,
    alpha_l: ArrayLike,
    alpha_r: ArrayLike,
    x_v: ArrayLike,
    y_l: ArrayLike,
    y_r: ArrayLike,
) -> Twist:
    """Asymmetric extended differential drive (Baril eq. 7).

    The ICR model with a slip factor per track: ``v_l`` and ``v_r`` are first
    scaled by ``alpha_l`` and ``alpha_r``. ``x_v`` is the body ICR's forward
    coordinate (our ``x_icr``).

    Returns
    -------
    v_x, v_y, omega : ndarray
        Body twist (m/s, m/s, rad/s).
    """
    v_l, v_r, alpha_l, alpha_r = _as_float(v_l, v_r, alpha_l, alpha_r)
    return twist_icr(alpha_l * v_l, alpha_r * v_r, y_l, y_r, x_v)


def twist_roc(
    v_l: ArrayLike,
    v_r: ArrayLike,
    alpha: ArrayLike,
    beta_1: ArrayLike,
    beta_2: ArrayLike,
    track_width: ArrayLike,
) -> Twist:
    """Radius-of-curvature model (Baril eq. 10-11, after Wang et al.).

    The symmetric extended differential drive with an effective half width
    ``y_0 = B/2 * (1 + beta_1 / (1 + beta_2 * sqrt(lambda)))`` that depends on
    the path curvature variable ``lambda = |(v_r + v_l) / (v_r - v_l)|``. On a
    straight line (``v_l == v_r``) the yaw rate is zero whatever ``y_0``.

    Parameters
    ----------
    alpha : array_like
        Longitudinal slip factor, dimensionless.
    beta_1, beta_2 : array_like
        Curvature-law coefficients, dimensionless.
    track_width : array_like
        Nominal track width ``B``, m.

    Returns
    -------
    v_x, v_y, omega : ndarray
        Body twist (m/s, m/s, rad/s). Where ``y_0`` is not positive the yaw
        rate is NaN (an invalid parameter set, for an optimiser to reject).
    """
    v_l, v_r, alpha, beta_1, beta_2, b = _as_float(v_l, v_r, alpha, beta_1, beta_2, track_width)
    diff = v_r - v_l
    turning = diff != 0.0
    lam = np.abs(v_r + v_l) / np.where(turning, np.abs(diff), 1.0)
    denom = 1.0 + beta_2 * np.sqrt(lam)
    safe = denom != 0.0
    y_0 = 0.5 * b * (1.0 + beta_1 / np.where(safe, denom, 1.0))
    valid = safe & (y_0 > 0.0)
    omega = np.where(turning, alpha * diff / np.where(valid, 2.0 * y_0, 1.0), 0.0)
    omega = np.where(turning & ~valid, np.nan, omega)
    return _twist(alpha * 0.5 * (v_l + v_r), 0.0, omega)


def twist_linear(
    v_l: ArrayLike,
    v_r: ArrayLike,
    g11: ArrayLike,
    g12: ArrayLike,
    g21: ArrayLike,
    g22: ArrayLike,
    g31: ArrayLike,
    g32: ArrayLike,
) -> Twist:
    """Full linear model (Baril eq. 12, after Anousaki et al.).

    ``[v_x, v_y, omega] = G @ [v_l, v_r]``. Note that our inputs are surface
    speeds, so ``G`` here is Baril's gamma matrix divided by the wheel radius:
    ``g1j, g2j`` are dimensionless and ``g3j`` are in 1/m.

    Returns
    -------
    v_x, v_y, omega : ndarray
        Body twist (m/s, m/s, rad/s).
    """
    v_l, v_r = _as_float(v_l, v_r)
    g = _as_float(g11, g12, g21, g22, g31, g32)
    return _twist(g[0] * v_l + g[1] * v_r, g[2] * v_l + g[3] * v_r, g[4] * v_l + g[5] * v_r)


def twist_icr(
    v_l: ArrayLike,
    v_r: ArrayLike,
    y_l: ArrayLike,
    y_r: ArrayLike,
    x_icr: ArrayLike,
    alpha: ArrayLike = 1.0,
) -> Twist:
    """Track-ICR model (Chen eq. 3 = Martinez eq. 7-9), optional slip factor.

    .. math::

        v_x = \\alpha\\frac{v_r y_l - v_l y_r}{y_l - y_r},\\quad
        \\omega = \\alpha\\frac{v_r - v_l}{y_l - y_r},\\quad
        v_y = -\\omega\\, x_{icr}

    Parameters
    ----------
    v_l, v_r : array_like
        Track surface speeds, m/s.
    y_l, y_r : array_like
        Lateral coordinates of the left and right track ICRs, m; ``y_l > y_r``.
    x_icr : array_like
        Forward coordinate of the ICRs, m.
    alpha : array_like, optional
        Longitudinal slip factor multiplying both track speeds (1 = none).

    Returns
    -------
    v_x, v_y, omega : ndarray
        Body twist (m/s, m/s, rad/s).

    Raises
    ------
    ValueError
        If ``y_l <= y_r`` anywhere (the model is singular there).

    Examples
    --------
    With ``y_l = -y_r = B/2`` and ``x_icr = 0`` it is the ideal differential drive:

    >>> [float(a) for a in twist_icr(0.5, 1.5, 0.25, -0.25, 0.0)]
    [1.0, -0.0, 2.0]
    """
    v_l, v_r, y_l, y_r, x_icr, alpha = _as_float(v_l, v_r, y_l, y_r, x_icr, alpha)
    _check_icr_spacing(y_l, y_r)
    d = y_l - y_r
    v_x = alpha * (v_r * y_l - v_l * y_r) / d
    omega = alpha * (v_r - v_l) / d
    return _twist(v_x, -omega * x_icr, omega)


def twist_icr_jacobian(
    v_l: ArrayLike,
    v_r: ArrayLike,
    y_l: ArrayLike,
    y_r: ArrayLike,
    x_icr: ArrayLike,
    alpha: ArrayLike = 1.0,
) -> np.ndarray:
    """Jacobian of :func:`twist_icr` with respect to its parameters.

    Returns
    -------
    ndarray, shape (..., 3, 4)
        ``d(v_x, v_y, omega) / d(y_l, y_r, x_icr, alpha)``.
    """
    v_l, v_r, y_l, y_r, x_icr, alpha = np.broadcast_arrays(
        *_as_float(v_l, v_r, y_l, y_r, x_icr, alpha)
    )
    _check_icr_spacing(y_l, y_r)
    d = y_l - y_r
    omega = alpha * (v_r - v_l) / d
    jac = np.zeros(v_l.shape + (3, 4))
    # v_x = alpha (v_r y_l - v_l y_r) / d
    jac[..., 0, 0] = alpha * y_r * (v_l - v_r) / d**2
    jac[..., 0, 1] = alpha * y_l * (v_r - v_l) / d**2
    jac[..., 0, 3] = (v_r * y_l - v_l * y_r) / d
    # omega = alpha (v_r - v_l) / d
    jac[..., 2, 0] = -omega / d
    jac[..., 2, 1] = omega / d
    jac[..., 2, 3] = (v_r - v_l) / d
    # v_y = -omega x_icr
    jac[..., 1, :] = -x_icr[..., None] * jac[..., 2, :]
    jac[..., 1, 2] = -omega
    return jac


def steering_efficiency(y_l: ArrayLike, y_r: ArrayLike, track_width: float) -> np.ndarray:
    """Steering efficiency ``c = (y_l - y_r) / B`` (Martinez eq. 12); 1 = no skid."""
    y_l, y_r = _as_float(y_l, y_r)
    return (y_l - y_r) / float(track_width)


def eccentricity(y_l: ArrayLike, y_r: ArrayLike) -> np.ndarray:
    """Eccentricity ``e`` of the track ICRs (Martinez eq. 13) in our axes.

    ``e = (x_ICRr + x_ICRl) / (x_ICRr - x_ICRl) = -(y_l + y_r) / (y_l - y_r)``;
    positive when the ICRs are shifted to the right (the left track slips less).
    """
    y_l, y_r = _as_float(y_l, y_r)
    _check_icr_spacing(y_l, y_r)
    return -(y_l + y_r) / (y_l - y_r)


def icr_from_chen(y_l: float, y_r: float, x_g: float) -> tuple[float, float, float]:
    """Convert Chen et al.'s ``(y_l, y_r, x_G)`` to ours ``(y_l, y_r, x_icr)``."""
    return float(y_l), float(y_r), -float(x_g)


def icr_from_martinez(x_icr_l: float, x_icr_r: float, y_icr: float) -> tuple[float, float, float]:
    """Convert Martinez et al.'s ``(x_ICRl, x_ICRr, y_ICR)`` to ``(y_l, y_r, x_icr)``."""
    return -float(x_icr_l), -float(x_icr_r), float(y_icr)


def icr_to_martinez(y_l: float, y_r: float, x_icr: float) -> tuple[float, float, float]:
    """Convert ``(y_l, y_r, x_icr)`` to Martinez et al.'s ``(x_ICRl, x_ICRr, y_ICR)``."""
    return -float(y_l), -float(y_r), float(x_icr)


@dataclass(frozen=True)
class KinematicModel:
    """One member of the model family, with what an optimiser needs.

    Attributes
    ----------
    name : str
        Short name used on the command line (``idd``, ``edd-sym`` ...).
    param_names : tuple of str
        Names of the trainable parameters, in order.
    bounds : tuple of (float, float)
        Search bounds per parameter (Baril Table I, made finite).
    needs_track_width : bool
        Whether the twist function takes the nominal track width ``B`` last.
    twist_fn : callable
        ``twist_fn(v_l, v_r, *params[, B]) -> (v_x, v_y, omega)``.
    """

    name: str
    param_names: tuple[str, ...]
    bounds: tuple[tuple[float, float], ...]
    needs_track_width: bool
    twist_fn: Callable[..., Twist]

    def twist(
        self, v_l: ArrayLike, v_r: ArrayLike, params: ArrayLike, track_width: float | None = None
    ) -> Twist:
        """Evaluate the model.

        Parameters
        ----------
        v_l, v_r : array_like, shape (N,)
            Track surface speeds, m/s.
        params : array_like, shape (..., len(param_names))
            Parameter values; leading axes broadcast against the speeds
            after a trailing axis is added (``(P, k)`` gives ``(P, N)``).
        track_width : float, optional
            Nominal track width ``B``, m; required when ``needs_track_width``.

        Returns
        -------
        v_x, v_y, omega : ndarray
            Body twist (m/s, m/s, rad/s).
        """
        p = np.asarray(params, dtype=float)
        if p.shape[-1:] != (len(self.param_names),):
            raise ValueError(
                f"model {self.name!r} takes {len(self.param_names)} parameters "
                f"{self.param_names}, got an array of shape {p.shape}"
            )
        columns = [p[..., i, None] if p.ndim > 1 else p[i] for i in range(p.shape[-1])]
        if self.needs_track_width:
            if track_width is None:
                raise ValueError(f"model {self.name!r} needs the nominal track_width")
            columns.append(track_width)
        return self.twist_fn(v_l, v_r, *columns)


_BIG = 50.0  # m: finite stand-in for Baril's unbounded ICR coordinates

MODELS: dict[str, KinematicModel] = {
    m.name: m
    for m in (
        KinematicModel("idd", (), (), True, twist_idd),
        KinematicModel(
            "edd-sym", ("alpha", "b_hat"), ((0.0, 1.5), (0.1, _BIG)), False, twist_edd_sym
        ),
        KinematicModel(
            "edd-asym",
            ("alpha_l", "alpha_r", "x_v", "y_l", "y_r"),
            ((0.0, 1.5), (0.0, 1.5), (-_BIG, _BIG), (0.05, _BIG), (-_BIG, -0.05)),
            False,
            twist_edd_asym,
        ),
        KinematicModel(
            "roc",
            ("alpha", "beta_1", "beta_2"),
            # Baril: beta in R; these keep y_0 > 0 for every curvature (no singular twist)
            ((0.0, 1.5), (-0.95, _BIG), (0.0, _BIG)),
            True,
            twist_roc,
        ),
        KinematicModel(
            "linear",
            ("g11", "g12", "g21", "g22", "g31", "g32"),
            ((-2.0, 2.0), (-2.0, 2.0), (-2.0, 2.0), (-2.0, 2.0), (-5.0, 0.0), (0.0, 5.0)),
            False,
            twist_linear,
        ),
        KinematicModel(
            "icr",
            ("y_l", "y_r", "x_icr"),
            ((0.05, _BIG), (-_BIG, -0.05), (-_BIG, _BIG)),
            False,
            twist_icr,
        ),
        KinematicModel(
            "icr-slip",
            ("y_l", "y_r", "x_icr", "alpha"),
            ((0.05, _BIG), (-_BIG, -0.05), (-_BIG, _BIG), (0.0, 1.5)),
            False,
            twist_icr,
        ),
    )
}


def get_model(name: str) -> KinematicModel:
    """Look up a model by name, with a clear error listing the choices."""
    try:
        return MODELS[name]
    except KeyError:
        raise ValueError(
            f"unknown kinematic model {name!r}; choose one of {sorted(MODELS)}"
        ) from None
