"""Extended Kalman filter over the pose and the track ICRs (Chen et al. 2023).

The state, the process model (the ICR model integrated exactly over each
wheel sample, the parameters a random walk) and the heading sensor's bias
state are :mod:`~terrain_odom.estimation.icr_model`. The measurement is the
pose (or any subset of ``x, y, yaw``) as the mounted sensors read it
(:func:`~terrain_odom.estimation.pose_measurement.measurement`), with the
yaw innovation wrapped.

Differences from the printed paper, all deliberate:

- The discrete Jacobian is that of the exact discrete step
  (:func:`~terrain_odom.estimation.icr_model.icr_step_with_jacobian`; the
  printed eq. 8 and 9 are wrong for large steps and in two signs).
- Process noise is a continuous-time density: ``Q = diag(sigma_q**2) * dt``.
- The covariance update is filterpy's Joseph form, then symmetrised.

The predict and update run as compiled kernels
(:mod:`terrain_odom.estimation._kernels`, ~1 us per wheel sample); they
are the filterpy formulation written out, and the tests hold them to a
filterpy ``ExtendedKalmanFilter`` driven by
:func:`~terrain_odom.estimation.icr_model.icr_step_with_jacobian` within
1e-12 on simulated and real logs.
- After every update the ICR state is clipped to physical limits that
  follow the robot (``y_l`` and ``-y_r`` within 0.2 to 3 track widths,
  ``|x_icr|`` within half its length), so ``y_l - y_r`` never reaches zero.
- Pose updates pass a chi-square gate on their innovation (positions and
  headings separately), with re-acquisition after rejections in a row.

References
----------
.. [1] Chen et al., "Kinematics Model Estimation of 4W Skid-Steering Mobile
   Robots Using Visual Terrain Classification", J. Robotics 2023, eq. 4-16.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from statistics import NormalDist

import numpy as np
from numpy.typing import ArrayLike

from terrain_odom.config import (
    EkfConfig,
    IcrLimits,
    IcrSigmas,
    IcrState,
    PoseGate,
    RobotConfig,
    TerrainConfig,
)
from terrain_odom.errors import EstimationError
from terrain_odom.estimation import _kernels
from terrain_odom.estimation.icr_model import HeadingBias, state_names
from terrain_odom.kinematics import wrap_angle
from terrain_odom.kinematics.mounting import Mounting
from terrain_odom.records import TerrainChange

__all__ = [
    "IcrEkf",
    "IcrPriors",
    "gate_bounds",
]

logger = logging.getLogger(__name__)

_POSE = slice(0, 3)
_YAW = 2
_NON_FINITE = "EKF state became non-finite; check the noise configuration"


def gate_bounds(gate: PoseGate) -> tuple[float, float]:
    """Return the NIS bounds of a position (2 degrees of freedom) and a heading (1).

    The ``gate.probability`` quantiles of the chi-square distribution
    (``inf`` when the gate is off, and for headings unless ``gate.headings``):
    ``-2 ln(1 - p)`` and the square of the normal quantile of ``(1 + p) / 2``.

    Examples
    --------
    >>> [round(b, 2) for b in gate_bounds(PoseGate(probability=0.999, headings=True))]
    [13.82, 10.83]
    """
    if not gate.enabled:
        return math.inf, math.inf
    p = gate.probability
    heading = NormalDist().inv_cdf(0.5 + 0.5 * p) ** 2 if gate.headings else math.inf
    return -2.0 * math.log1p(-p), heading


@dataclass(frozen=True)
class IcrPriors:
    """Offline ICR parameters that seed the filter (``terrain-odom run --priors``).

    Attributes
    ----------
    terrains : mapping of str to IcrState
        Parameters per terrain label: the estimate when the filter starts on
        that terrain or changes to it.
    start : IcrState or None
        One set for every terrain: the initial estimate only (it says
        nothing about a terrain the robot changes to).

    Examples
    --------
    >>> from terrain_odom.config import IcrState
    >>> priors = IcrPriors(terrains={"grass": IcrState(0.42, -0.40, 0.05, 0.93)})
    >>> sorted(priors.terrains)
    ['grass']
    """

    terrains: Mapping[str, IcrState] = field(default_factory=dict)
    start: IcrState | None = None


class IcrEkf:
    """Online estimator of the pose and the track ICRs of a skid-steer robot.

    Parameters
    ----------
    config : EkfConfig
        Initial state, noise and limits.
    terrain : TerrainConfig, optional
        Terrain adaptation settings (reset to ``P_B``, terrain memory).
    pose : array_like, shape (3,), optional
        Initial pose ``x, y, yaw``; the origin if omitted.
    priors : IcrPriors, optional
        Offline ICR parameters: ``priors.start`` replaces
        ``config.initial``; a terrain's prior seeds the estimate when the
        filter starts on it or changes to it (see
        :meth:`reset_on_terrain_change`), with covariance
        ``config.sigma_prior**2``.
    mounting : Mounting, optional
        Antenna lever arm and heading offset of the pose sensors
        (:mod:`~terrain_odom.kinematics.mounting`); none by default.
    robot : RobotConfig, optional
        The robot whose track width and length give the initial ICRs and
        their limits where ``config`` leaves them ``None``
        (:meth:`~terrain_odom.config.InitialIcrs.resolve`,
        :meth:`~terrain_odom.config.EkfLimits.resolve`); the defaults if omitted.
    heading_bias : HeadingBias, optional
        Estimate the heading sensor's slow bias as the last state (starting
        at 0 with std ``sigma``); none by default (the state ends with the
        ICRs, as without heading measurements).

    Attributes
    ----------
    limits : IcrLimits
        The bounds the ICR state is clipped into, m.
    gating : ndarray, shape (8,)
        The pose gate's state: time (filter clock, s) of the first of the
        current rejections of positions and of headings (NaN: none), their
        number, then the counts of rejected positions, rejected headings,
        re-acquired positions, re-acquired headings.

    Examples
    --------
    >>> from terrain_odom.config import EkfConfig
    >>> ekf = IcrEkf(EkfConfig())
    >>> ekf.predict(1.0, 1.0, 0.1)
    >>> ekf.pose.round(3).tolist()
    [0.1, 0.0, 0.0]
    """

    def __init__(
        self,
        config: EkfConfig,
        terrain: TerrainConfig | None = None,
        *,
        pose: ArrayLike | None = None,
        priors: IcrPriors | None = None,
        mounting: Mounting | None = None,
        robot: RobotConfig | None = None,
        heading_bias: HeadingBias | None = None,
    ) -> None:
        robot = robot if robot is not None else RobotConfig()
        self.config = config
        self.mounting = mounting if mounting is not None else Mounting()
        self.terrain_config = terrain if terrain is not None else TerrainConfig()
        self.priors = priors if priors is not None else IcrPriors()
        self.heading_bias = heading_bias
        self.names = state_names(config.estimate_alpha, heading_bias is not None)
        n = self._model = len(state_names(config.estimate_alpha))  # pose, ICRs(, alpha)
        ini = config.initial.resolve(robot)
        if not ini.y_l > ini.y_r:
            raise EstimationError(f"initial ICRs need y_l > y_r, got y_l={ini.y_l}, y_r={ini.y_r}")
        x0 = np.array([0.0, 0.0, 0.0, ini.y_l, ini.y_r, ini.x_icr, ini.alpha])[:n]
        if pose is not None:
            x0[_POSE] = np.asarray(pose, dtype=float)
            x0[_YAW] = wrap_angle(x0[_YAW])
        p0, q_density = self._sigmas(config.sigma_p0) ** 2, self._sigmas(config.sigma_q) ** 2
        self._bias = np.empty(0)  # the kernels' bias argument: its time constant, if estimated
        if heading_bias is not None:
            if not (heading_bias.sigma > 0.0 and math.inf > heading_bias.tau > 0.0):
                raise EstimationError(f"a heading bias needs sigma, tau > 0, got {heading_bias}")
            x0 = np.append(x0, 0.0)
            p0 = np.append(p0, heading_bias.sigma**2)
            q_density = np.append(q_density, 0.0)  # the kernels add the bias's own
            self._bias = np.array([heading_bias.tau, heading_bias.sigma**2])
        self._x = x0
        self._P = np.diag(p0)
        self._q_density = q_density
        self._r_diag = np.array([config.sigma_r.x, config.sigma_r.y, config.sigma_r.yaw]) ** 2
        self._r = np.diag(self._r_diag)
        self.limits: IcrLimits = config.limits.resolve(robot)
        lim = self.limits
        self._limits = np.array(
            [lim.half_width_min, lim.half_width_max, lim.x_icr_max, lim.alpha_min, lim.alpha_max]
        )
        gate = config.gate
        self._gate = np.array([*gate_bounds(gate), gate.reacquire_after, gate.reacquire])
        self.gating = np.array([math.nan, math.nan, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
        self.t = 0.0
        self.terrain: str | None = None
        self._terrain_since = 0.0
        self._memory: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        self.last_nis = float("nan")
        if self.priors.start is not None:
            self._seed(self.priors.start)

    # ----------------------------------------------------------------- state
    def _sigmas(self, sig: object, names: tuple[str, ...] | None = None) -> np.ndarray:
        """``sig``'s values of ``names`` (default: the model's states, without a bias)."""
        return np.array([getattr(sig, n) for n in names or self.names[: self._model]], dtype=float)

    @property
    def x(self) -> np.ndarray:
        """State vector, shape (n,)."""
        return self._x.copy()

    @property
    def P(self) -> np.ndarray:  # noqa: N802 - the paper's symbol
        """State covariance, shape (n, n)."""
        return self._P.copy()

    @property
    def pose(self) -> np.ndarray:
        """Estimated pose ``x, y, yaw`` (m, m, rad)."""
        return self._x[_POSE].copy()

    @property
    def params(self) -> np.ndarray:
        """ICR parameters ``y_l, y_r, x_icr(, alpha)``."""
        return self._x[3 : self._model].copy()

    @property
    def bias(self) -> float:
        """Estimated heading bias, rad (0 when not estimated)."""
        return float(self._x[-1]) if self._bias.size else 0.0

    @property
    def std(self) -> np.ndarray:
        """Standard deviation of every state, shape (n,)."""
        return _kernels.std(self._P)

    # ------------------------------------------------------------ filtering
    def predict(self, v_l: float, v_r: float, dt: float) -> None:
        """Propagate over one wheel sample held for ``dt`` seconds.

        Parameters
        ----------
        v_l, v_r : float
            Track surface speeds, m/s.
        dt : float
            Duration, s (> 0).

        Raises
        ------
        EstimationError
            ``dt`` is not positive or a track speed is not finite.
        """
        if not dt > 0.0:
            raise EstimationError(f"predict needs dt > 0 s, got {dt}")
        if not (math.isfinite(v_l) and math.isfinite(v_r)):
            raise EstimationError(f"predict needs finite track speeds, got {v_l}, {v_r} m/s")
        _kernels.icr_predict(
            self._x, self._P, self._q_density, float(v_l), float(v_r), float(dt), self._bias
        )
        self.t += dt

    def update(self, z: ArrayLike, *, R: ArrayLike | None = None) -> float:  # noqa: N803
        """Fuse a pose measurement; NaN components are left out.

        The measurement is the pose sensors' (:attr:`mounting`): antenna
        position and sensor heading (:func:`~terrain_odom.estimation.pose_measurement.measurement`).

        A heading without a position leaves ``alpha`` unchanged. A heading
        measures the turn rate ``alpha (v_r - v_l) / (y_l - y_r)``, to which
        a slip factor and a wider ICR spacing are the same; letting it move
        ``alpha`` too scales the distance by a factor nothing measured
        (on the Jackal bag of docs/bags.md it shrank the path from 84 m to
        37 m). So alpha's gain row is zero (a Schmidt, or consider, update):
        the other states get the Kalman gain and ``P`` follows the Joseph
        form, the covariance of any gain, so alpha's variance stays and its
        covariances with the updated states change consistently.

        The position and the heading each pass a chi-square gate on their
        innovation first (``config.gate``; :func:`gate_bounds`): one beyond
        it is not fused (a GPS jump), unless ``gate.reacquire_after``
        components of its kind in a row, or all for ``gate.reacquire``
        seconds, were rejected before it: then the pose variances grow by its
        innovation squared and it is fused (the filter re-acquires after an
        outage). :attr:`gating` counts both.

        Parameters
        ----------
        z : array_like, shape (3,)
            Measured ``x, y, yaw`` (m, m, rad); NaN where not measured (e.g.
            heading only during a GPS outage, position only from a GPS);
            ``x`` without ``y`` is left out.
        R : array_like, shape (3,) or (3, 3), optional
            Measurement noise (variances) overriding the configured one.

        Returns
        -------
        float
            Normalised innovation squared of the components fused (NaN if
            nothing was measured or all were rejected).
        """
        z = np.asarray(z, dtype=float)
        if R is None:
            r_full = self._r
        else:
            r_full = np.asarray(R, dtype=float)
            r_full = np.diag(r_full) if r_full.ndim == 1 else r_full
        nis, finite = _kernels.icr_update(
            self._x,
            self._P,
            z,
            r_full,
            self._mounting_array(),
            self._limits,
            self._gate,
            self.gating,
            self.t,
            self._bias,
        )
        if not finite:
            raise EstimationError(_NON_FINITE)
        if not math.isnan(nis):  # NaN: nothing measured, nothing done
            self.last_nis = nis
        return nis

    def run_rows(
        self,
        since: tuple[float, float, float],
        t: np.ndarray,
        speeds: tuple[np.ndarray, np.ndarray],
        z: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, int]:
        """Predict and update over a stretch of log rows in one compiled call.

        Row ``i`` is :meth:`predict` from the previous row's time with the
        speeds held since, then :meth:`update` with ``z[i]`` if it has a
        measured component: what calling them row by row gives, bit for bit.

        Parameters
        ----------
        since : tuple of float
            Time (s) and track speeds (m/s) of the wheel sample before ``t[0]``.
        t : ndarray, shape (B,)
            Row times, s, increasing from ``since[0]`` on.
        speeds : tuple of ndarray, each of shape (B,)
            ``v_l, v_r`` of each row, m/s (held until the next row).
        z : ndarray, shape (B, 3)
            Measured ``x, y, yaw`` of each row; NaN where not measured.

        Returns
        -------
        states, stds : ndarray, shape (B, n)
            The state and its standard deviations after each row.
        updates : int
            Rows whose pose updated the filter.

        Raises
        ------
        EstimationError
            Time does not advance, a track speed is not finite, or the state
            became non-finite.
        """
        steps = np.diff(t, prepend=since[0])
        if steps.size and not steps.min() > 0.0:
            raise EstimationError(f"predict needs dt > 0 s, got {steps.min()}")
        if not (math.isfinite(since[1]) and math.isfinite(since[2])) or not all(
            np.isfinite(s).all() for s in speeds
        ):
            raise EstimationError("predict needs finite track speeds (a NaN or inf in the rows)")
        held = np.array([*since, self.t])
        states, stds = np.empty((t.size, self._x.size)), np.empty((t.size, self._x.size))
        noise = (
            self._q_density,
            self._r,
            self._mounting_array(),
            self._limits,
            self._gate,
            self._bias,
        )
        rows = (t, *speeds, np.ascontiguousarray(z, dtype=float))
        updates, nis, bad = _kernels.icr_rows(
            self._x, self._P, noise, rows, held, self.gating, states, stds
        )
        if bad >= 0:
            raise EstimationError(_NON_FINITE)
        self.t = float(held[3])
        if not math.isnan(nis):
            self.last_nis = float(nis)
        return states, stds, int(updates)

    def _mounting_array(self) -> np.ndarray:
        """:attr:`mounting` as the kernels take it: ``antenna_x, antenna_y, heading_offset``."""
        sensor = self.mounting
        return np.array([sensor.antenna_x, sensor.antenna_y, sensor.heading_offset])

    def _constrain(self) -> None:
        """Wrap yaw (and a heading bias), clip the ICR state into its limits, symmetrise P."""
        if not _kernels.constrain(self._x, self._P, self._limits, self._model):
            raise EstimationError(_NON_FINITE)

    def reset_pose(self, pose: ArrayLike, sigma: ArrayLike | None = None) -> None:
        """Re-anchor the pose (e.g. at the first measurement of a log segment).

        The ICR parameters and their covariance are kept; the pose covariance
        is set to ``sigma**2`` (the measurement noise by default) and its
        correlation with the parameters is cleared; the gate's rejections
        in a row are forgotten.
        """
        x = self._x
        x[_POSE] = np.asarray(pose, dtype=float)
        x[_YAW] = wrap_angle(x[_YAW])
        var = self._r_diag if sigma is None else np.asarray(sigma, dtype=float) ** 2
        P = self._P  # noqa: N806
        P[_POSE, :] = 0.0
        P[:, _POSE] = 0.0
        P[_POSE, _POSE] = np.diag(var)
        self.gating[:4] = [math.nan, math.nan, 0.0, 0.0]

    def anchor_heading(self, heading: float, sigma: float) -> None:
        """Re-anchor the yaw at a measured heading: ``heading - heading_offset - b``.

        As :meth:`reset_pose` with the position kept and the yaw's std
        ``sigma`` (rad). With a bias state the yaw's error is minus the bias
        estimate's plus the heading's noise: its covariance with every
        state is minus ``b``'s, its variance ``sigma**2 + var(b)``.
        """
        pose, std = self.pose, self.std[:3]
        pose[_YAW] = wrap_angle(heading - self.mounting.heading_offset - self.bias)
        std[_YAW] = sigma
        self.reset_pose(pose, std)
        if self._bias.size:
            P = self._P  # noqa: N806
            row = -P[-1]
            row[_YAW] = sigma**2 + P[-1, -1]
            P[_YAW, :] = row
            P[:, _YAW] = row

    # ---------------------------------------------------- terrain adaptation
    def set_terrain(self, label: str) -> None:
        """Name the terrain the filter is on, without a ``P_B`` reset.

        The first terrain named (the one the filter starts on) seeds the ICR
        estimate from its prior, if :attr:`priors` has one; later calls only
        rename (terrain adaptation off).
        """
        label = str(label)
        prior = self.priors.terrains.get(label) if self.terrain is None else None
        if prior is not None:
            self._seed(prior)
        self.terrain = label
        self._terrain_since = self.t

    def _set_icr_block(self, cov: np.ndarray, estimate: np.ndarray | None = None) -> None:
        """Set the ICR covariance (and estimate), uncorrelated with the rest."""
        P, icr = self._P, slice(3, self._model)  # noqa: N806
        P[icr, :] = 0.0
        P[:, icr] = 0.0
        P[icr, icr] = cov
        if estimate is not None:
            self._x[icr] = estimate
            self._constrain()

    def _seed(self, prior: IcrState) -> None:
        """Set the ICR estimate to ``prior`` with covariance ``sigma_prior**2``."""
        icr = self.names[3 : self._model]
        estimate = np.array([prior.y_l, prior.y_r, prior.x_icr, prior.alpha])[: len(icr)]
        cov = np.diag(self._sigmas(self.config.sigma_prior, icr) ** 2)
        self._set_icr_block(cov, estimate)

    def _inflate_pose(self) -> None:
        """Add ``sigma_pb_pose**2`` to the pose variances (kept uncorrelated with the ICRs)."""
        sig = self.config.sigma_pb_pose
        self._P[_POSE, _POSE] += np.diag(np.square([sig.x, sig.y, sig.yaw]))

    def _pb_variances(self, label: str) -> np.ndarray:
        sig: IcrSigmas = self.config.sigma_pb_per_terrain.get(label, self.config.sigma_pb)
        return self._sigmas(sig, self.names[3 : self._model]) ** 2

    def reset_on_terrain_change(self, label: str) -> TerrainChange:
        """Apply a confirmed change to terrain ``label``.

        Sets the ICR block of ``P`` to ``P_B`` (per terrain if configured) and
        clears its correlation with the pose, so the filter re-converges
        quickly (Chen et al. 2023, Sec. 3.2). Chen resets the whole ``P``;
        here the pose variances grow by ``sigma_pb_pose**2`` instead (they
        are never made smaller than they are): a change is applied a little
        after the robot crossed, and the pose error the old terrain's model
        left meanwhile (a few hundredths of a radian in a sharp turn, many
        times the settled yaw deviation) would otherwise be read as ICR
        error by the first updates, which then overshoot. With terrain memory, the ICR
        estimate and covariance of the terrain being left are remembered (if
        the robot stayed there at least ``memory_min_dwell`` s), and those of
        ``label``, if remembered, are restored instead of ``P_B``: the filter
        resumes where it left that terrain. Otherwise, if :attr:`priors` has
        a set for ``label``, the ICR estimate is set to it with covariance
        ``sigma_prior**2``: a robot calibrated on that terrain re-converges
        at once. A remembered estimate wins over the prior: on the first
        visit the filter started from the prior, so what it remembers is
        that prior updated by the drive, and more recent.

        Returns
        -------
        TerrainChange
            What was done.
        """
        label = str(label)
        tc = self.terrain_config
        previous = self.terrain
        if (
            tc.memory
            and previous is not None
            and self.t - self._terrain_since >= tc.memory_min_dwell
        ):
            self._memory[previous] = (self.params, self._P[3 : self._model, 3 : self._model].copy())
        restored = tc.memory and label in self._memory
        prior = None if restored else self.priors.terrains.get(label)
        if restored:
            estimate, cov = self._memory[label]
            self._set_icr_block(cov, estimate)
        elif prior is not None:
            self._seed(prior)
        else:
            self._set_icr_block(np.diag(self._pb_variances(label)))
        self._inflate_pose()
        change = TerrainChange(self.t, previous, label, bool(restored), prior=prior is not None)
        logger.info(
            "terrain %s -> %s at t=%.2f s (restored=%s, prior=%s)",
            previous,
            label,
            self.t,
            restored,
            prior is not None,
        )
        self.terrain = label
        self._terrain_since = self.t
        return change
