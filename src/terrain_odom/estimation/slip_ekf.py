"""Slip-parameter EKF for low-rate pose sensors (the 2016 tracked-vehicle slip model).

The model (:mod:`terrain_odom.kinematics.slip`, :class:`~terrain_odom.kinematics.slip.SlipModel`):
the track ICRs are linear in six parameters ``l1 .. l6`` over two features of
the track speeds (lateral acceleration and curvature), optionally with a
longitudinal slip factor ``alpha``; ``l = 0`` (and ``alpha = 1``) is the
ideal differential drive.

The filter state is the parameter vector ``l1 .. l6(, alpha)`` only: the
pose is not a state, the parameters follow a random walk. At each pose
measurement the measurement is, as in the paper, the pose change over the
last few seconds: since the latest earlier pose measurement at least
``slip_ekf.window`` seconds before (0: the previous one), expressed in the
frame of that measured pose (``relative_pose``); the prediction integrates
the recorded wheel speeds over that interval (exact arcs, zero-order hold)
with the current parameters; the Jacobian is analytic (chain rule through
arcs and composition; tested against finite differences). The pose noise of
overlapping windows is independent unless they share an end, and a longer
change is measured with the same noise, so a window of a few tenths of a
second makes each update informative enough to linearise well at 10 Hz.
Any subset of ``dx, dy, dyaw`` may be measured (:meth:`SlipEkf.update`
leaves NaN components out; the streaming API fuses position changes between
fixes and heading changes between headings); a heading change alone leaves
``alpha`` alone (it cannot tell a slip factor from a wider ICR spacing).
Positions without any heading (a GPS alone) are fused by
:meth:`SlipEkf.update_course`: the length of a chord between fixes and its
turn from the chord before, all that positions measure up to a rotation.

References
----------
.. [1] "Slip model of tracked vehicles based on ICRs", Mathematical Problems
   in Engineering 2016, article 6375652 (equations reconstructed, see docs/models.md).
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import numpy as np
from filterpy.kalman import ExtendedKalmanFilter
from numpy.typing import ArrayLike

from terrain_odom.config import SlipEkfConfig, SlipSigmas, TerrainConfig
from terrain_odom.errors import EstimationError
from terrain_odom.estimation.pose_measurement import chord_turn
from terrain_odom.kinematics import wrap_angle
from terrain_odom.kinematics.slip import SlipModel, param_names
from terrain_odom.records import TerrainChange

__all__ = ["OUTPUT_NAMES", "SlipEkf"]

logger = logging.getLogger(__name__)

OUTPUT_NAMES = ("x", "y", "yaw", "y_l", "y_r", "x_icr")
"""Per-row outputs before the parameters: dead-reckoned pose and current ICRs."""


class SlipEkf:
    """Online estimator of the slip parameters from low-rate pose changes.

    Parameters
    ----------
    config : SlipEkfConfig
        Initial parameters, noise, features and ICR limits.
    track_width : float
        Nominal track width ``B``, m.
    terrain : TerrainConfig, optional
        Terrain adaptation (reset of ``P`` to ``P_B``, terrain memory).

    Examples
    --------
    >>> from terrain_odom.config import SlipEkfConfig
    >>> ekf = SlipEkf(SlipEkfConfig(), 1.0)
    >>> nis = ekf.update([0.5, 0.0, 0.0], [1.0] * 5, [1.0] * 5, [0.1] * 5)  # straight
    >>> ekf.params.round(6).tolist()
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]
    """

    def __init__(
        self,
        config: SlipEkfConfig,
        track_width: float,
        terrain: TerrainConfig | None = None,
    ) -> None:
        if not track_width > 0.0:
            raise EstimationError(f"slip EKF needs a track width > 0 m, got {track_width}")
        self.config = config
        self.model = SlipModel.from_config(config, track_width)
        self.terrain_config = terrain if terrain is not None else TerrainConfig()
        self.names = param_names(config.estimate_alpha)
        n = len(self.names)
        self._filter = ExtendedKalmanFilter(dim_x=n, dim_z=3)
        self._filter.x = self._sigmas(config.initial)[:, None]
        self._filter.P = np.diag(self._sigmas(config.sigma_p0) ** 2)
        self._q_density = self._sigmas(config.sigma_q) ** 2
        r = config.sigma_r
        self._r_diag = np.array([r.dx, r.dy, r.dyaw]) ** 2
        self.t = 0.0
        self.terrain: str | None = None
        self._terrain_since = 0.0
        self._memory: dict[str, np.ndarray] = {}
        self.last_nis = float("nan")

    def _sigmas(self, values: object) -> np.ndarray:
        return np.array([getattr(values, name) for name in self.names], dtype=float)

    @property
    def x(self) -> np.ndarray:
        """Parameter vector ``l1 .. l6(, alpha)``, shape (n,)."""
        return self._filter.x[:, 0].copy()

    params = x

    @property
    def P(self) -> np.ndarray:  # noqa: N802 - the usual symbol
        """Parameter covariance, shape (n, n)."""
        return self._filter.P.copy()

    @property
    def std(self) -> np.ndarray:
        """Standard deviation of every parameter, shape (n,)."""
        return np.sqrt(np.clip(np.diag(self._filter.P), 0.0, None))

    def icrs(self, v_l: ArrayLike, v_r: ArrayLike) -> tuple[np.ndarray, ...]:
        """Return the current ICRs ``y_l, y_r, x_icr`` (m) at these track speeds (m/s)."""
        return self.model.icrs(self.x, *self.model.features(v_l, v_r))

    def icr_std(self, v_l: float, v_r: float) -> np.ndarray:
        """Return the std of ``y_l, y_r, x_icr`` at these speeds (linearised), m."""
        _, jac = self.model.icrs_with_jacobian(self.x, *self.model.features(v_l, v_r))
        cov = jac[:3] @ self._filter.P @ jac[:3].T
        return np.sqrt(np.clip(np.diag(cov), 0.0, None))

    # ------------------------------------------------------------ filtering
    def predict(self, dt: float) -> None:
        """Random walk of the parameters over ``dt`` seconds (>= 0): ``P += Q dt``."""
        if not dt >= 0.0:
            raise EstimationError(f"predict needs dt >= 0 s, got {dt}")
        self._filter.P = self._filter.P + np.diag(self._q_density * dt)
        self.t += dt

    def update(
        self,
        z: ArrayLike,
        v_l: ArrayLike,
        v_r: ArrayLike,
        dt: ArrayLike,
        *,
        R: ArrayLike | None = None,  # noqa: N803
    ) -> float:
        """Fuse a measured pose change; NaN components are left out.

        Parameters
        ----------
        z : array_like, shape (3,)
            Measured ``dx, dy, dyaw`` since an earlier pose measurement, in
            the frame of that pose (m, m, rad); ``dx, dy`` NaN for heading only.
        v_l, v_r, dt : array_like, shape (K,)
            The recorded track speeds (m/s) over the interval and how long
            each was held (s).
        R : array_like, shape (3,), optional
            Measurement variances overriding the configured ones.

        Returns
        -------
        float
            Normalised innovation squared (NaN if nothing was measured).
        """
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
        """Fuse two consecutive position chords without a heading (a GPS alone).

        Parameters
        ----------
        z : array_like, shape (2,)
            Measured length of the second chord (m) and turn from the first
            chord's direction to the second's (rad):
            :func:`~terrain_odom.estimation.pose_measurement.chord_turn`.
        first, second : tuple of 3 array_like
            ``(v_l, v_r, dt)`` of the wheel samples over each chord.
        antenna : array_like, shape (2,)
            Position sensor in the robot frame, m.
        R : array_like, shape (2,)
            Measurement variances (m^2, rad^2).

        Returns
        -------
        float
            Normalised innovation squared.
        """

        def predict(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            c1, j1 = self.model.pose_change_with_jacobian(x, *first)
            c2, j2 = self.model.pose_change_with_jacobian(x, *second)
            return chord_turn(c1, j1, c2, j2, antenna)

        r = np.diag(np.asarray(R, dtype=float))
        return self._iterated_update(np.asarray(z, dtype=float), r, predict, np.array([1]))

    def _iterated_update(
        self,
        z: np.ndarray,
        r: np.ndarray,
        predict: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
        angle_rows: np.ndarray,
    ) -> float:
        """Fuse measurement ``z`` (noise ``r``) predicted by ``predict``: an iterated EKF update.

        ``predict(x)`` returns ``h(x)`` and ``dh/dx``; ``angle_rows`` are the
        rows whose residual is wrapped. Returns the normalised innovation squared.
        """
        x0, p0 = self.x, self._filter.P

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
        self._filter.update(
            z[:, None],
            HJacobian=lambda _x: H,
            Hx=lambda x: (h + H @ (x[:, 0] - x_last))[:, None],
            R=r,
            residual=lambda a, b: residual(a[:, 0], b[:, 0])[:, None],
        )
        y = self._filter.y
        self.last_nis = float((y.T @ self._filter.SI @ y).item())
        self._filter.P = 0.5 * (self._filter.P + self._filter.P.T)
        if not (np.all(np.isfinite(self._filter.x)) and np.all(np.isfinite(self._filter.P))):
            raise EstimationError("slip EKF state became non-finite; check the noise configuration")
        return self.last_nis

    # ---------------------------------------------------- terrain adaptation
    def set_terrain(self, label: str) -> None:
        """Name the terrain the filter starts on, without any reset."""
        self.terrain = str(label)
        self._terrain_since = self.t

    def reset_on_terrain_change(self, label: str) -> TerrainChange:
        """Reset ``P`` to ``P_B`` on a confirmed change to terrain ``label``.

        With terrain memory the parameters of the terrain being left are kept
        (after ``memory_min_dwell`` s there) and those remembered for
        ``label`` are restored.
        """
        label, tc = str(label), self.terrain_config
        dwelt = self.t - self._terrain_since >= tc.memory_min_dwell
        if tc.memory and self.terrain is not None and dwelt:
            self._memory[self.terrain] = self.x
        restored = tc.memory and label in self._memory
        if restored:
            self._filter.x = self._memory[label][:, None].copy()
        pb: SlipSigmas = self.config.sigma_pb
        self._filter.P = np.diag(self._sigmas(pb) ** 2)
        change = TerrainChange(self.t, self.terrain, label, bool(restored))
        logger.info("slip EKF: terrain %s -> %s at t=%.2f s", self.terrain, label, self.t)
        self.set_terrain(label)
        return change


def _outlier_inflation(innovation: np.ndarray, hph: np.ndarray, r: np.ndarray) -> float:
    """Factor (>= 1) on ``R`` that brings the innovation back to the 99 % chi-square bound.

    ``hph`` is ``H P H^T`` and ``r`` the measurement covariance; the
    normalised innovation squared ``y^T (HPH^T + R)^-1 y`` above the bound of
    its dimension marks an outlier (ICP stamp jitter), whose noise is then
    taken as that much larger.
    """
    nis = float(innovation @ np.linalg.solve(hph + r, innovation))
    return max(1.0, nis / _CHI2_99[innovation.size])


_CHI2_99 = {1: 6.635, 2: 9.210, 3: 11.345}
"""99 % quantiles of the chi-square distribution with 1, 2 and 3 degrees of freedom."""
