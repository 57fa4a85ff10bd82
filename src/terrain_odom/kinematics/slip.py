"""The 2016 tracked-vehicle slip model: ICRs as functions of speed features.

The track ICRs are functions of two features of the track surface speeds
``v_l, v_r`` (m/s) and the nominal track width ``B`` (m):

- lateral acceleration ``a = |v * omega_0|`` (m/s^2) with ``v = (v_l + v_r) / 2``
  and ``omega_0 = (v_r - v_l) / B`` (the no-slip yaw rate);
- curvature ``k = |v_r - v_l| / (|v_l| + |v_r| + eps)``, bounded to [0, 1]
  (0 straight, 1 turning on the spot);

.. math::

    y_l = B/2 + l_1 a + l_2 k,\\quad
    y_r = -(B/2 + l_3 a + l_4 k),\\quad
    x_{icr} = l_5 a + l_6 k,

optionally with the longitudinal slip factor ``alpha`` multiplying both track
speeds. ``l = 0`` (and ``alpha = 1``) is the ideal differential drive. The
ICRs are clipped into configured bounds, so ``y_l - y_r`` never reaches 0.
The body twist is :func:`~terrain_odom.kinematics.twist_icr` of these ICRs.
The filter that estimates ``l`` online is
:class:`~terrain_odom.estimation.slip_ekf.SlipEkf`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from terrain_odom.config import IcrLimits, SlipEkfConfig
from terrain_odom.kinematics.integration import arc_increment_with_jacobian, integrate
from terrain_odom.kinematics.models import twist_icr, twist_icr_jacobian

__all__ = ["PARAM_NAMES", "param_names", "SlipModel"]


PARAM_NAMES = ("l1", "l2", "l3", "l4", "l5", "l6", "alpha")


def param_names(estimate_alpha: bool) -> tuple[str, ...]:
    """Names of the filter's parameters, in order; ``alpha`` last when estimated."""
    return PARAM_NAMES if estimate_alpha else PARAM_NAMES[:6]


@dataclass(frozen=True)
class SlipModel:
    """The parameterised ICR slip model: features, ICRs, twist, pose change.

    Attributes
    ----------
    track_width : float
        Nominal track width ``B``, m.
    eps : float
        Regulariser of the curvature denominator, m/s.
    lateral_acceleration, curvature : bool
        Which features are used (a feature switched off is 0).
    limits : IcrLimits
        Bounds the ICRs are clipped into.

    Examples
    --------
    >>> from terrain_odom.config import IcrLimits
    >>> m = SlipModel(2.0, 1e-3, True, True, IcrLimits())
    >>> [round(float(f), 4) for f in m.features(1.0, 3.0)]  # v = 2, omega_0 = 1
    [2.0, 0.4999]
    >>> [float(c) for c in m.icrs(np.zeros(6), *m.features(1.0, 3.0))]  # l = 0: no slip
    [1.0, -1.0, 0.0]
    """

    track_width: float
    eps: float
    lateral_acceleration: bool
    curvature: bool
    limits: IcrLimits

    @classmethod
    def from_config(cls, config: SlipEkfConfig, track_width: float) -> SlipModel:
        """Build the model of a ``slip_ekf`` config section and a nominal ``B`` (m)."""
        c = config
        return cls(float(track_width), c.eps, c.lateral_acceleration, c.curvature, c.limits)

    def features(self, v_l: ArrayLike, v_r: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Lateral acceleration ``a`` (m/s^2) and curvature ``k`` (in [0, 1]).

        Parameters
        ----------
        v_l, v_r : array_like
            Track surface speeds, m/s (broadcast).

        Returns
        -------
        a, k : ndarray
            ``|v * omega_0|`` and ``|v_r - v_l| / (|v_l| + |v_r| + eps)``; 0
            for a feature switched off.
        """
        v_l, v_r = np.broadcast_arrays(np.asarray(v_l, float), np.asarray(v_r, float))
        diff = v_r - v_l
        a = np.abs(0.5 * (v_l + v_r) * diff / self.track_width)
        k = np.abs(diff) / (np.abs(v_l) + np.abs(v_r) + self.eps)
        return a * self.lateral_acceleration, k * self.curvature

    def icrs_with_jacobian(
        self, params: ArrayLike, a: ArrayLike, k: ArrayLike
    ) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray], np.ndarray]:
        """ICRs and slip factor from the parameters, and their Jacobian.

        Parameters
        ----------
        params : array_like, shape (..., n)
            ``l1 .. l6(, alpha)``, n = 6 or 7; broadcast against ``a, k``.
        a, k : array_like
            Features from :meth:`features`.

        Returns
        -------
        (y_l, y_r, x_icr, alpha) : tuple of ndarray
            Clipped ICRs (m) and slip factor (1 when not estimated).
        jacobian : ndarray, shape (..., 4, n)
            ``d(y_l, y_r, x_icr, alpha) / d params`` of the unclipped
            functions, so that a filter pushed past a bound is still pulled
            back by later measurements (a clipped zero slope would trap it).
        """
        p = np.asarray(params, dtype=float)
        n = p.shape[-1]
        a, k = np.asarray(a, dtype=float), np.asarray(k, dtype=float)
        values = self._icr_values(p, a, k)
        shape = np.broadcast_shapes(p.shape[:-1], a.shape, k.shape)
        a, k = np.broadcast_to(a, shape), np.broadcast_to(k, shape)
        jac = np.zeros(shape + (4, n))
        jac[..., 0, 0], jac[..., 0, 1] = a, k
        jac[..., 1, 2], jac[..., 1, 3] = -a, -k
        jac[..., 2, 4], jac[..., 2, 5] = a, k
        if n > 6:
            jac[..., 3, 6] = 1.0
        return values, jac

    def _icr_values(
        self, p: np.ndarray, a: np.ndarray, k: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Clipped ``y_l, y_r, x_icr, alpha`` of :meth:`icrs_with_jacobian`, no Jacobian.

        ``np.minimum(np.maximum(...))`` is what ``np.clip`` computes, without
        its Python wrapper (this runs several times per filter row).
        """
        half, lim = 0.5 * self.track_width, self.limits
        raw = (
            half + p[..., 0] * a + p[..., 1] * k,
            -(half + p[..., 2] * a + p[..., 3] * k),
            p[..., 4] * a + p[..., 5] * k,
            p[..., 6] if p.shape[-1] > 6 else np.ones_like(a),
        )
        lo = (lim.half_width_min, -lim.half_width_max, -lim.x_icr_max, lim.alpha_min)
        hi = (lim.half_width_max, -lim.half_width_min, lim.x_icr_max, lim.alpha_max)
        y_l, y_r, x_icr, alpha = (
            np.minimum(np.maximum(r, lo[i]), hi[i]) for i, r in enumerate(raw)
        )
        return y_l, y_r, x_icr, alpha

    def icrs(self, params: ArrayLike, a: ArrayLike, k: ArrayLike) -> tuple[np.ndarray, ...]:
        """Clipped ICRs ``y_l, y_r, x_icr`` (m) of :meth:`icrs_with_jacobian`."""
        p, a, k = (np.asarray(x, dtype=float) for x in (params, a, k))
        return self._icr_values(p, a, k)[:3]

    def twist(
        self, v_l: ArrayLike, v_r: ArrayLike, params: ArrayLike
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Body twist ``v_x, v_y, omega`` (m/s, m/s, rad/s) of the slip model.

        ``params`` has shape ``(..., n)`` and broadcasts against the speeds.
        """
        a, k = self.features(v_l, v_r)
        return twist_icr(v_l, v_r, *self._icr_values(np.asarray(params, dtype=float), a, k))

    def pose_change_with_jacobian(
        self, params: ArrayLike, v_l: ArrayLike, v_r: ArrayLike, dt: ArrayLike
    ) -> tuple[np.ndarray, np.ndarray]:
        """Pose change over a run of wheel samples, and its parameter Jacobian.

        Each sample's twist is held for its ``dt`` (exact arc); the arcs are
        composed. ``d pose_N / d inc_i = [[R(yaw_i), perp(p_N - p_(i+1))], [0, 0, 1]]``
        chains with the arc, twist and ICR Jacobians.

        Parameters
        ----------
        params : array_like, shape (n,)
            ``l1 .. l6(, alpha)``.
        v_l, v_r, dt : array_like, shape (K,)
            Track speeds (m/s) and hold durations (s) of the samples.

        Returns
        -------
        change : ndarray, shape (3,)
            ``dx, dy, dyaw`` in the start frame (m, m, rad; yaw wrapped).
        jacobian : ndarray, shape (3, n)
            ``d change / d params``.
        """
        v_l, v_r, dt = (np.atleast_1d(np.asarray(x, dtype=float)) for x in (v_l, v_r, dt))
        values, j_icr = self.icrs_with_jacobian(params, *self.features(v_l, v_r))
        twist = twist_icr(v_l, v_r, *values)
        j_twist = twist_icr_jacobian(v_l, v_r, *values)
        _, j_arc = arc_increment_with_jacobian(*twist, dt)
        poses = integrate(*twist, dt)
        end = poses[-1]
        c, s = np.cos(poses[:-1, 2]), np.sin(poses[:-1, 2])
        j_comp = np.zeros((dt.size, 3, 3))
        j_comp[:, 0, 0], j_comp[:, 0, 1], j_comp[:, 1, 0], j_comp[:, 1, 1] = c, -s, s, c
        j_comp[:, 0, 2] = -(end[1] - poses[1:, 1])
        j_comp[:, 1, 2] = end[0] - poses[1:, 0]
        j_comp[:, 2, 2] = 1.0
        # sum_k J_comp J_arc J_twist J_icr: per-sample 3x4 products, then one
        # matrix product over (k, 4) (an unoptimised 4-operand einsum cost 10-60x)
        chain = (j_comp @ j_arc) @ j_twist
        jac = chain.transpose(1, 0, 2).reshape(3, -1) @ j_icr.reshape(-1, j_icr.shape[-1])
        return end, jac

    def pose_change(
        self, params: ArrayLike, v_l: ArrayLike, v_r: ArrayLike, dt: ArrayLike
    ) -> np.ndarray:
        """Return the pose change of :meth:`pose_change_with_jacobian`."""
        v_l, v_r, dt = (np.atleast_1d(np.asarray(x, dtype=float)) for x in (v_l, v_r, dt))
        return integrate(*self.twist(v_l, v_r, params), dt)[-1]
