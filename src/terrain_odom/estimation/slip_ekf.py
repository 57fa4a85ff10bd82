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

The arithmetic runs in compiled kernels (:mod:`~terrain_odom.estimation._slip_kernels`,
numba, the process's first calls as Python); the numpy and filterpy
formulation they replace is kept as the reference
(:class:`~terrain_odom.estimation.slip_ekf_reference.FilterpySlipEkf`).

References
----------
.. [1] "Slip model of tracked vehicles based on ICRs", Mathematical Problems
   in Engineering 2016, article 6375652 (equations reconstructed, see docs/models.md).
"""

from __future__ import annotations

import logging

import numpy as np
from numpy.typing import ArrayLike

from terrain_odom.config import SlipEkfConfig, SlipSigmas, TerrainConfig
from terrain_odom.errors import EstimationError
from terrain_odom.estimation import _slip_kernels as kernels  # looked up per call: see there
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
        self._x = self._sigmas(config.initial)
        self._P = np.diag(self._sigmas(config.sigma_p0) ** 2)
        self._model = model_constants(self.model)
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
        return self._x.copy()

    params = x

    @property
    def P(self) -> np.ndarray:  # noqa: N802 - the usual symbol
        """Parameter covariance, shape (n, n)."""
        return self._P.copy()

    @property
    def std(self) -> np.ndarray:
        """Standard deviation of every parameter, shape (n,)."""
        return np.sqrt(np.clip(np.diag(self._P), 0.0, None))

    def icrs(self, v_l: ArrayLike, v_r: ArrayLike) -> tuple[np.ndarray, ...]:
        """Return the current ICRs ``y_l, y_r, x_icr`` (m) at these track speeds (m/s)."""
        return self.model.icrs(self.x, *self.model.features(v_l, v_r))

    def icr_std(self, v_l: float, v_r: float) -> np.ndarray:
        """Return the std of ``y_l, y_r, x_icr`` at these speeds (linearised), m."""
        _, jac = self.model.icrs_with_jacobian(self.x, *self.model.features(v_l, v_r))
        cov = jac[:3] @ self._P @ jac[:3].T
        return np.sqrt(np.clip(np.diag(cov), 0.0, None))

    def estimate(self, pose: np.ndarray, v_l: float, v_r: float) -> tuple[np.ndarray, np.ndarray]:
        """Return a log row's state and its standard deviations.

        Parameters
        ----------
        pose : ndarray, shape (3,)
            The dead-reckoned pose ``x, y, yaw`` (m, m, rad).
        v_l, v_r : float
            The held track speeds, m/s.

        Returns
        -------
        state : ndarray, shape (6 + n,)
            ``pose``, the ICRs ``y_l, y_r, x_icr`` at the speeds (:meth:`icrs`),
            the parameters.
        std : ndarray, shape (6 + n,)
            NaN for the pose, then :meth:`icr_std` and :attr:`std`.
        """
        return kernels.slip_estimate(pose, self._x, self._P, float(v_l), float(v_r), self._model)

    # ------------------------------------------------------------ filtering
    def predict(self, dt: float) -> None:
        """Random walk of the parameters over ``dt`` seconds (>= 0): ``P += Q dt``."""
        if not dt >= 0.0:
            raise EstimationError(f"predict needs dt >= 0 s, got {dt}")
        kernels.slip_predict(self._P, self._q_density, float(dt))
        self.t += dt

    def dead_reckon(self, pose: np.ndarray, v_l: float, v_r: float, dt: float) -> None:
        """Advance ``pose`` (``x, y, yaw``, float array) in place over one wheel sample.

        The twist of the current parameters at track speeds ``v_l, v_r``
        (m/s), held ``dt`` s (an exact arc).
        """
        kernels.dead_reckon(pose, self._x, float(v_l), float(v_r), float(dt), self._model)

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
        if not np.isfinite(z).any():
            return float("nan")
        r = self._r_diag if R is None else np.asarray(R, dtype=float)
        return self._fuse(z, r, _samples(v_l, v_r, dt), -1, _NO_ANTENNA)

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
        head, tail = _samples(*first), _samples(*second)
        z, r = (np.asarray(a, dtype=float) for a in (z, R))
        arm = np.asarray(antenna, dtype=float)
        return self._fuse(z, r, np.hstack([head, tail]), head.shape[1], arm)

    def _fuse(
        self, z: np.ndarray, r: np.ndarray, samples: np.ndarray, split: int, antenna: np.ndarray
    ) -> float:
        """Run :func:`~terrain_odom.estimation._slip_kernels.slip_update`; return the NIS."""
        options = (int(self.config.iterations), bool(self.config.robust))  # one numba signature
        nis, finite = kernels.slip_update(
            self._x, self._P, z, r, samples, split, self._model, antenna, *options
        )
        self.last_nis = float(nis)
        if not finite:
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
            self._x = self._memory[label].copy()
        pb: SlipSigmas = self.config.sigma_pb
        self._P = np.diag(self._sigmas(pb) ** 2)
        change = TerrainChange(self.t, self.terrain, label, bool(restored))
        logger.info("slip EKF: terrain %s -> %s at t=%.2f s", self.terrain, label, self.t)
        self.set_terrain(label)
        return change


def model_constants(model: SlipModel) -> np.ndarray:
    """Return the constants of ``model`` as the kernels take them, shape (9,).

    ``B, eps``, lateral acceleration and curvature on (1) or off (0), then
    the limits ``half_width_min, half_width_max, x_icr_max, alpha_min, alpha_max``.
    """
    lim = model.limits
    return np.array(
        [model.track_width, model.eps, model.lateral_acceleration, model.curvature]
        + [lim.half_width_min, lim.half_width_max, lim.x_icr_max, lim.alpha_min, lim.alpha_max],
        dtype=float,
    )


def _samples(v_l: ArrayLike, v_r: ArrayLike, dt: ArrayLike) -> np.ndarray:
    """Return wheel samples ``v_l, v_r, dt`` (each shape (K,), broadcast) as rows, (3, K)."""
    return np.vstack(
        np.broadcast_arrays(*(np.atleast_1d(np.asarray(a, float)) for a in (v_l, v_r, dt)))
    )


_NO_ANTENNA = np.zeros(2)  # a pose change uses no lever arm
