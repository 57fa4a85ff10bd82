"""The slip EKF in its numpy and filterpy formulation: the reference of the compiled kernels.

:class:`FilterpySlipEkf` is :class:`~terrain_odom.estimation.slip_ekf.SlipEkf`
with dead reckoning, row estimates and updates done as before the kernels
of :mod:`terrain_odom.estimation._slip_kernels`: the pose change and its
Jacobian by :meth:`~terrain_odom.kinematics.slip.SlipModel.pose_change_with_jacobian`
(numpy over the samples), Gauss-Newton iterations with numpy's inverse, the
final step through a filterpy ``ExtendedKalmanFilter`` (Joseph form),
:func:`~terrain_odom.kinematics.compose` for dead reckoning. The random walk
``P += Q dt`` is inherited (one addition per diagonal element either way),
and so are terrain resets and memory, so both run the same logs through the
same streaming path. The tests hold the kernels to it within 1e-12 and
``bench/slip_ekf.py --speed`` times both; it imports filterpy (and SciPy's
statistics) on first use.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from terrain_odom.errors import EstimationError
from terrain_odom.estimation._slip_kernels import CHI2_99
from terrain_odom.estimation.pose_measurement import chord_turn
from terrain_odom.estimation.slip_ekf import SlipEkf
from terrain_odom.kinematics import compose, wrap_angle

__all__ = ["FilterpySlipEkf"]

Measurement = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]


class FilterpySlipEkf(SlipEkf):
    """:class:`~terrain_odom.estimation.slip_ekf.SlipEkf` in numpy and filterpy (the reference)."""

    def estimate(self, pose: np.ndarray, v_l: float, v_r: float) -> tuple[np.ndarray, np.ndarray]:
        """Return a log row's state and std from :meth:`icrs` and :meth:`icr_std` (numpy)."""
        icr = np.array([float(c) for c in self.icrs(v_l, v_r)])
        state = np.concatenate([pose, icr, self.x])
        std = np.concatenate([np.full(3, np.nan), self.icr_std(v_l, v_r), self.std])
        return state, std

    def dead_reckon(self, pose: np.ndarray, v_l: float, v_r: float, dt: float) -> None:
        """Advance ``pose`` in place by the model's pose change over the sample (numpy)."""
        pose[:] = compose(pose, self.model.pose_change(self.x, v_l, v_r, dt))

    def update(
        self,
        z: ArrayLike,
        v_l: ArrayLike,
        v_r: ArrayLike,
        dt: ArrayLike,
        *,
        R: ArrayLike | None = None,  # noqa: N803
    ) -> float:
        """Fuse a measured pose change (see :meth:`SlipEkf.update`)."""
        z = np.asarray(z, dtype=float)
        rows = np.flatnonzero(np.isfinite(z))
        if rows.size == 0:
            return float("nan")
        r = np.diag((self._r_diag if R is None else np.asarray(R, dtype=float))[rows])
        freeze = np.arange(len(self.names)) < 6  # heading only: alpha not observable, kept

        def predict(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            change, jac = self.model.pose_change_with_jacobian(x, v_l, v_r, dt)
            return change[rows], jac[rows] * freeze if rows.size == 1 else jac[rows]

        return self._iterated_update(z[rows], r, predict, np.flatnonzero(rows == 2))

    def update_course(
        self,
        z: ArrayLike,
        first: tuple[ArrayLike, ArrayLike, ArrayLike],
        second: tuple[ArrayLike, ArrayLike, ArrayLike],
        antenna: ArrayLike,
        R: ArrayLike,  # noqa: N803
    ) -> float:
        """Fuse two consecutive position chords (see :meth:`SlipEkf.update_course`)."""

        def predict(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            c1, j1 = self.model.pose_change_with_jacobian(x, *first)
            c2, j2 = self.model.pose_change_with_jacobian(x, *second)
            return chord_turn(c1, j1, c2, j2, antenna)

        r = np.diag(np.asarray(R, dtype=float))
        return self._iterated_update(np.asarray(z, dtype=float), r, predict, np.array([1]))

    def _iterated_update(
        self, z: np.ndarray, r: np.ndarray, predict: Measurement, angle_rows: np.ndarray
    ) -> float:
        """Fuse measurement ``z`` (noise ``r``) predicted by ``predict``: an iterated EKF update.

        ``predict(x)`` returns ``h(x)`` and ``dh/dx``; ``angle_rows`` are the
        rows whose residual is wrapped. Returns the normalised innovation squared.
        """
        x0, p0 = self.x, self._P

        def residual(a: np.ndarray, b: np.ndarray) -> np.ndarray:
            res = a - b
            res[angle_rows] = wrap_angle(res[angle_rows])
            return res

        x_i = x0
        for i in range(self.config.iterations):  # Gauss-Newton on the measurement (IEKF)
            h, H = predict(x_i)  # noqa: N806
            if i == 0 and self.config.robust:
                r = r * _outlier_inflation(residual(z, h), H @ p0 @ H.T, r)
            gain = p0 @ H.T @ np.linalg.inv(H @ p0 @ H.T + r)
            x_last, x_i = x_i, x0 + gain @ (residual(z, h) - H @ (x0 - x_i))
        # The final step through filterpy (Joseph form), linearised at the last iterate.
        ekf = _filterpy_ekf(x0, p0)
        ekf.update(
            z[:, None],
            HJacobian=lambda _x: H,
            Hx=lambda x: (h + H @ (x[:, 0] - x_last))[:, None],
            R=r,
            residual=lambda a, b: residual(a[:, 0], b[:, 0])[:, None],
        )
        y = ekf.y
        self.last_nis = float((y.T @ ekf.SI @ y).item())
        self._x, self._P = ekf.x[:, 0].copy(), 0.5 * (ekf.P + ekf.P.T)
        if not (np.all(np.isfinite(self._x)) and np.all(np.isfinite(self._P))):
            raise EstimationError("slip EKF state became non-finite; check the noise configuration")
        return self.last_nis


def _filterpy_ekf(x: np.ndarray, p: np.ndarray) -> Any:
    """Return a filterpy EKF at state ``x`` and covariance ``p``."""
    from filterpy.kalman import ExtendedKalmanFilter

    ekf = ExtendedKalmanFilter(dim_x=x.size, dim_z=3)
    ekf.x, ekf.P = x[:, None].copy(), p.copy()
    return ekf


def _outlier_inflation(innovation: np.ndarray, hph: np.ndarray, r: np.ndarray) -> float:
    """Factor (>= 1) on ``R`` that brings the innovation back to the 99 % chi-square bound.

    ``hph`` is ``H P H^T`` and ``r`` the measurement covariance; the
    normalised innovation squared ``y^T (HPH^T + R)^-1 y`` above the bound of
    its dimension marks an outlier (ICP stamp jitter), whose noise is then
    taken as that much larger.
    """
    nis = float(innovation @ np.linalg.solve(hph + r, innovation))
    return max(1.0, nis / CHI2_99[innovation.size])
