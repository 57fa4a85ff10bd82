"""The configuration sections: frozen dataclasses with the defaults of ``config/default.yaml``.

The defaults of these dataclasses are the values in ``config/default.yaml``
(a test keeps the two equal). Noise values are standard deviations:
``sigma_p0``, ``sigma_pb`` and ``sigma_prior`` in the state's units,
``sigma_r`` in the measurement's units, and ``sigma_q`` as continuous-time
noise densities in units per square-root second (the discrete process noise
over a step of ``dt`` seconds is ``sigma_q**2 * dt``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

from terrain_odom.config.camera import CameraConfig, RoiConfig
from terrain_odom.config.classifier import ClassifierConfig
from terrain_odom.config.fields import NON_NEGATIVE, SIGNED
from terrain_odom.errors import ConfigError

__all__ = [
    "FORMAT_VERSION",
    "RobotConfig",
    "IcrState",
    "PoseIcrSigmas",
    "PoseSigmas",
    "IcrSigmas",
    "IcrLimits",
    "EkfLimits",
    "InitialIcrs",
    "PoseGate",
    "LENGTH_PER_TRACK",
    "HALF_WIDTH_PER_TRACK",
    "EkfConfig",
    "TerrainConfig",
    "EvaluationConfig",
    "SlipParams",
    "SlipSigmas",
    "PoseChangeSigmas",
    "SlipEkfConfig",
    "TimeConfig",
    "ChecksConfig",
    "PoseSensorConfig",
    "MAX_POSE_DELAY",
    "MAX_ANTENNA_OFFSET",
    "ROBOT_SIZE",
    "Config",
]

FORMAT_VERSION = 1
LENGTH_PER_TRACK = 1.5
"""Default ``robot.length`` per metre of ``robot.track_width``."""
HALF_WIDTH_PER_TRACK = (0.2, 3.0)
"""Default bounds of the ICR EKF's ``y_l`` and ``-y_r`` per metre of track width: the ICR
spacing ``y_l - y_r`` stays within 0.4 to 6 track widths (Martinez et al. 2004 measured 1.85 on
a tracked robot on hard ground, the Warthog's effective track is ~1.7 of its nominal one)."""
MAX_POSE_DELAY = 5.0
"""Largest ``time.pose_delay`` accepted, s (beyond it a value is a unit mistake, not a latency)."""
MAX_ANTENNA_OFFSET = 10.0
"""Largest ``pose_sensor.antenna_x`` / ``antenna_y`` accepted, m (beyond: centimetres?)."""
ROBOT_SIZE = (1e-3, 100.0)
"""Range of ``robot.wheel_radius``, ``track_width`` and ``length`` accepted, m: a ground robot's
(beyond: another unit, or a typing slip; the plausibility checks judge values within it)."""


@dataclass(frozen=True)
class RobotConfig:
    """Robot geometry.

    Attributes
    ----------
    wheel_radius : float
        Wheel (sprocket) radius, m; converts ``omega_l, omega_r`` to surface speed.
    track_width : float
        Nominal track width ``B``, m (distance between track centre lines).
    length : float or None
        Length of the robot's footprint along x, m: bounds the ICR EKF's
        ``|x_icr|`` to half of it (:class:`EkfLimits`). ``None``:
        :data:`LENGTH_PER_TRACK` times ``track_width`` (Warthog 1.52 m on a
        1.08-m track, Husky 0.99 m on 0.555 m, Jackal 0.51 m on 0.37 m).
    """

    wheel_radius: float = 0.1
    track_width: float = 0.5
    length: float | None = None

    def __post_init__(self) -> None:
        low, high = ROBOT_SIZE
        for name in ("wheel_radius", "track_width", "length"):
            value = getattr(self, name)
            if value is not None and not low <= value <= high:
                raise ConfigError(
                    f"{name}: {value:g} m is no ground robot's ({low * 1e3:g} mm to {high:g} m); "
                    "give metres"
                )

    @property
    def body_length(self) -> float:
        """:attr:`length`, or its default from the track width, m."""
        return self.length if self.length is not None else LENGTH_PER_TRACK * self.track_width


@dataclass(frozen=True)
class IcrState:
    """ICR parameters ``y_l, y_r, x_icr`` (m) and slip factor ``alpha``."""

    y_l: float = 0.25
    y_r: float = field(default=-0.25, metadata=SIGNED)
    x_icr: float = field(default=0.0, metadata=SIGNED)
    alpha: float = 1.0

    def resolve(self, robot: RobotConfig) -> IcrState:
        """Return these ICRs (already numbers): an ``IcrState`` serves as ``EkfConfig.initial``."""
        return self


@dataclass(frozen=True)
class InitialIcrs:
    """Initial ICR parameters of the ICR EKF: ``y_l, y_r, x_icr`` (m) and ``alpha``.

    ``y_l``/``y_r`` ``None``: half the robot's track width to the left / right
    (ideal differential drive), see :meth:`resolve`.
    """

    y_l: float | None = None
    y_r: float | None = field(default=None, metadata=SIGNED)
    x_icr: float = field(default=0.0, metadata=SIGNED)
    alpha: float = 1.0

    def resolve(self, robot: RobotConfig) -> IcrState:
        """Return the initial ICRs for ``robot`` (``None`` values from its track width)."""
        half = 0.5 * robot.track_width
        return IcrState(
            half if self.y_l is None else self.y_l,
            -half if self.y_r is None else self.y_r,
            self.x_icr,
            self.alpha,
        )


@dataclass(frozen=True)
class PoseIcrSigmas:
    """Standard deviations for every state: pose (m, m, rad) and ICR parameters."""

    x: float = 1.0
    y: float = 1.0
    yaw: float = 0.5
    y_l: float = 0.5
    y_r: float = 0.5
    x_icr: float = 0.5
    alpha: float = 0.1


@dataclass(frozen=True)
class PoseSigmas:
    """Standard deviations of a pose measurement: m, m, rad."""

    x: float = 0.05
    y: float = 0.05
    yaw: float = 0.02


@dataclass(frozen=True)
class IcrSigmas:
    """Standard deviations of the ICR parameters (m, m, m, dimensionless)."""

    y_l: float = 0.5
    y_r: float = 0.5
    x_icr: float = 0.5
    alpha: float = 0.1


@dataclass(frozen=True)
class IcrLimits:
    """Physical bounds the ICR state is kept in after every update.

    Attributes
    ----------
    half_width_min, half_width_max : float
        Bounds of ``y_l`` and ``-y_r``, m (``y_l - y_r`` never reaches 0).
    x_icr_max : float
        Bound of ``|x_icr|``, m.
    alpha_min, alpha_max : float
        Bounds of the slip factor.
    """

    half_width_min: float = 0.05
    half_width_max: float = 20.0
    x_icr_max: float = 10.0
    alpha_min: float = 0.3
    alpha_max: float = 1.5


@dataclass(frozen=True)
class EkfLimits:
    """Physical bounds the ICR EKF's state is clipped into after every update.

    By default they follow the robot (:meth:`resolve`): ``y_l`` and ``-y_r``
    within :data:`HALF_WIDTH_PER_TRACK` times the track width ``B`` (so
    ``y_l - y_r`` between ``0.4 B`` and ``6 B``), ``|x_icr|`` within half
    the robot's length (``robot.length``).

    Attributes
    ----------
    half_width_min, half_width_max : float or None
        Bounds of ``y_l`` and ``-y_r``, m; ``None``: ``0.2 B`` and ``3 B`` (the real Jackal bag's IMU asks for a spacing of 4.1 B).
    x_icr_max : float or None
        Bound of ``|x_icr|``, m; ``None``: half of ``robot.length``.
    alpha_min, alpha_max : float
        Bounds of the slip factor.
    """

    half_width_min: float | None = None
    half_width_max: float | None = None
    x_icr_max: float | None = None
    alpha_min: float = 0.3
    alpha_max: float = 1.5

    def resolve(self, robot: RobotConfig) -> IcrLimits:
        """Return the bounds for ``robot`` (``None`` values from its track width and length)."""
        low, high = (f * robot.track_width for f in HALF_WIDTH_PER_TRACK)
        return IcrLimits(
            low if self.half_width_min is None else self.half_width_min,
            high if self.half_width_max is None else self.half_width_max,
            0.5 * robot.body_length if self.x_icr_max is None else self.x_icr_max,
            self.alpha_min,
            self.alpha_max,
        )


@dataclass(frozen=True)
class PoseGate:
    """Chi-square gate of the ICR EKF's pose updates (positions and headings separately).

    Attributes
    ----------
    enabled : bool
        Gate the updates (``false``: every measured component is fused).
    headings : bool
        Gate the headings too (default: positions only). On the real Jackal
        bag's IMU (docs/bags.md) the heading gate rejected 31 of 3059
        headings and let the filter's yaw stray 0.042 rad from the IMU
        instead of 0.025.
    probability : float
        A position (2 degrees of freedom) or heading (1) whose normalised
        innovation squared lies beyond this quantile of the chi-square
        distribution is rejected (0.9999: 18.4 and 15.1; a shipped
        configuration's simulated logs have pose errors beyond 0.999).
    reacquire_after : int
        Rejections of a component in a row after which the next one beyond
        the bound is fused all the same: a lone jump is rejected, a filter
        truly off (after an outage, a reset) or meeting a sudden change of
        terrain re-acquires. Where its NIS is beyond ten bounds, the pose
        variance it measures is first grown in proportion, so the pose snaps
        back to the measurement without the ICRs taking the blame.
    reacquire : float
        Seconds of rejections in a row after which the same happens (for a
        fast sensor, e.g. an IMU at 50 Hz, with ``reacquire_after`` > 1), s.
    """

    enabled: bool = True
    headings: bool = False
    probability: float = 0.9999
    reacquire_after: int = 1
    reacquire: float = 1.0

    def __post_init__(self) -> None:
        if not 0.5 <= self.probability < 1.0:
            raise ConfigError(f"probability: must be in [0.5, 1), got {self.probability!r}")


@dataclass(frozen=True)
class EkfConfig:
    """Tuning of the ICR extended Kalman filter (Chen et al. 2023, eq. 4-16).

    Attributes
    ----------
    estimate_alpha : bool
        Add the longitudinal slip factor ``alpha`` to the state.
    initial : InitialIcrs
        Initial ICR parameters (``y_l, y_r`` from the track width unless set;
        an :class:`IcrState` gives them all).
    sigma_p0 : PoseIcrSigmas
        Initial standard deviations (``P0``).
    sigma_q : PoseIcrSigmas
        Process noise densities, unit / sqrt(s).
    sigma_r : PoseSigmas
        Pose measurement noise.
    sigma_pb : IcrSigmas
        Standard deviations the ICR block of ``P`` is reset to on a confirmed
        terrain change (``P_B``).
    sigma_pb_pose : PoseSigmas
        Added (in quadrature) to the pose's standard deviations on every
        applied terrain change, m, m, rad: the pose was predicted with the
        old terrain's model since the robot crossed, a fraction of a second
        the filter cannot time exactly.
    sigma_pb_per_terrain : dict of str to IcrSigmas
        Optional ``P_B`` per terrain label, overriding ``sigma_pb``.
    sigma_prior : IcrSigmas
        Standard deviations of an offline prior (``run --priors``): the ICR
        block of ``P`` wherever a fitted parameter set seeds the estimate,
        at the start or on a change to its terrain (instead of ``P_B``).
    limits : EkfLimits
        Bounds of the ICR state (following the robot unless set).
    gate : PoseGate
        Outlier gate of the pose updates.
    """

    estimate_alpha: bool = True
    initial: InitialIcrs = field(default_factory=InitialIcrs)
    sigma_p0: PoseIcrSigmas = field(default_factory=PoseIcrSigmas)
    sigma_q: PoseIcrSigmas = field(
        default_factory=lambda: PoseIcrSigmas(
            x=0.05, y=0.05, yaw=0.02, y_l=0.02, y_r=0.02, x_icr=0.02, alpha=0.002
        )
    )
    sigma_r: PoseSigmas = field(default_factory=PoseSigmas)
    sigma_pb: IcrSigmas = field(default_factory=IcrSigmas)
    sigma_pb_pose: PoseSigmas = field(default_factory=lambda: PoseSigmas(x=0.02, y=0.02, yaw=0.03))
    sigma_pb_per_terrain: dict[str, IcrSigmas] = field(default_factory=dict)
    sigma_prior: IcrSigmas = field(
        default_factory=lambda: IcrSigmas(y_l=0.05, y_r=0.05, x_icr=0.05, alpha=0.01)
    )
    limits: EkfLimits = field(default_factory=EkfLimits)
    gate: PoseGate = field(default_factory=PoseGate)


@dataclass(frozen=True)
class TerrainConfig:
    """Terrain adaptation.

    Attributes
    ----------
    adapt : bool
        Reset the ICR covariance to ``P_B`` on a confirmed terrain change.
    confirm : int
        Consecutive observations of a new label needed to confirm a change
        (Chen et al.: 2 frames).
    memory : bool
        On returning to a terrain seen before, restore its last ICR estimate.
    memory_min_dwell : float
        Seconds on a terrain before its estimate is remembered, s.
    reset_at : {"arrival", "immediate"}
        When a change confirmed by the camera is applied: ``arrival`` (beyond
        the paper) when the robot has travelled to the ground where the new
        terrain was first seen ahead; ``immediate`` (Chen et al.) at the
        confirming frame. Labels from the log describe the ground under the
        robot and are always applied at once.
    """

    adapt: bool = True
    confirm: int = 2
    memory: bool = True
    memory_min_dwell: float = 10.0
    reset_at: Literal["arrival", "immediate"] = "arrival"


@dataclass(frozen=True)
class SlipParams:
    """Slip parameters ``l1 .. l6`` and slip factor ``alpha`` (2016 slip model).

    ``l1, l3, l5`` multiply the lateral-acceleration feature (m per m/s^2,
    i.e. s^2), ``l2, l4, l6`` the curvature feature (m); all 0 is the
    no-slip model. See :mod:`terrain_odom.estimation.slip_ekf`.
    """

    l1: float = field(default=0.0, metadata=SIGNED)
    l2: float = field(default=0.0, metadata=SIGNED)
    l3: float = field(default=0.0, metadata=SIGNED)
    l4: float = field(default=0.0, metadata=SIGNED)
    l5: float = field(default=0.0, metadata=SIGNED)
    l6: float = field(default=0.0, metadata=SIGNED)
    alpha: float = 1.0


@dataclass(frozen=True)
class SlipSigmas:
    """Standard deviations of the slip parameters (units of :class:`SlipParams`)."""

    l1: float = 1.0
    l2: float = 1.0
    l3: float = 1.0
    l4: float = 1.0
    l5: float = 1.0
    l6: float = 1.0
    alpha: float = 0.1


@dataclass(frozen=True)
class PoseChangeSigmas:
    """Noise of a measured pose change, in the frame of the earlier pose: m, m, rad."""

    dx: float = 0.05
    dy: float = 0.05
    dyaw: float = 0.02


@dataclass(frozen=True)
class SlipEkfConfig:
    """Tuning of the slip-parameter EKF for low-rate pose sensors (2016 paper).

    Attributes
    ----------
    estimate_alpha : bool
        Add the longitudinal slip factor ``alpha`` to the parameters.
    lateral_acceleration, curvature : bool
        Use the lateral-acceleration feature ``a`` / the curvature feature
        ``k``; a feature switched off is taken as 0 (its parameters stay put).
    eps : float
        Regulariser of the curvature feature's denominator, m/s.
    iterations : int
        Gauss-Newton iterations of each measurement update (1: plain EKF,
        more: iterated EKF, which copes with large initial uncertainty).
    initial : SlipParams
        Initial parameters (all 0: the no-slip model).
    sigma_p0 : SlipSigmas
        Initial standard deviations (``P0``).
    sigma_q : SlipSigmas
        Random-walk densities of the parameters, unit / sqrt(s).
    window : float
        Length of the measured pose change, s: each update compares the pose
        change since the latest pose measurement at least ``window`` seconds
        earlier (the segment's first one while the segment is shorter) with
        its prediction; 0: since the previous measurement.
    sigma_r : PoseChangeSigmas
        Noise of the measured pose change between two pose measurements.
    robust : bool
        Take a pose change whose normalised innovation squared exceeds the
        99 % chi-square bound as an outlier: its noise is inflated by the
        ratio, so it moves the parameters no more than a change at the bound
        (for pose sensors with heavy-tailed errors, e.g. ICP stamp jitter).
    sigma_pb : SlipSigmas
        Standard deviations ``P`` is reset to on a confirmed terrain change.
    limits : IcrLimits
        Bounds the ICRs computed from the parameters are clipped into.
    """

    estimate_alpha: bool = True
    lateral_acceleration: bool = True
    curvature: bool = True
    eps: float = 1e-3
    iterations: int = 3
    window: float = field(default=0.0, metadata=NON_NEGATIVE)
    initial: SlipParams = field(default_factory=SlipParams)
    sigma_p0: SlipSigmas = field(default_factory=SlipSigmas)
    sigma_q: SlipSigmas = field(
        default_factory=lambda: SlipSigmas(
            l1=0.01, l2=0.01, l3=0.01, l4=0.01, l5=0.01, l6=0.01, alpha=0.001
        )
    )
    sigma_r: PoseChangeSigmas = field(default_factory=PoseChangeSigmas)
    robust: bool = False
    sigma_pb: SlipSigmas = field(default_factory=SlipSigmas)
    limits: IcrLimits = field(default_factory=IcrLimits)


@dataclass(frozen=True)
class EvaluationConfig:
    """Evaluation settings.

    Attributes
    ----------
    horizon : float
        ``h_e``, length of the model-odometry windows, m.
    icr_tolerance : float
        Half-width of the band the ICR estimate must stay in to count as
        re-converged after a terrain change, as a fraction of the robot's
        nominal track width (0.1: 5 cm for a 0.5-m robot).
    """

    horizon: float = 2.0
    icr_tolerance: float = 0.1


@dataclass(frozen=True)
class TimeConfig:
    """Temporal calibration of the pose stamps against the wheel speeds.

    Attributes
    ----------
    pose_delay : float or "auto"
        ``d``, s: a pose stamped ``t`` was measured at wheel time ``t - d``;
        the wheel speeds are delayed by ``d`` when the log is read
        (:func:`~terrain_odom.estimation.time_offset.delay_wheel_speeds`).
        ``auto``: estimated offline from the whole log (the heading changes,
        :func:`~terrain_odom.estimation.time_offset.estimate_pose_delay`, or
        without headings the positions,
        :func:`~terrain_odom.evaluation.calibration.fit_sensors`).
        0 (default): the stamps are taken as they are.
    position_delay, heading_delay : float, "auto" or None
        The delay of the position rows and of the heading rows, s, where
        they differ (a GPS ~0.5 s late, an IMU on time): ``auto`` estimates
        each from the whole log; None (default) takes ``pose_delay``. With
        two different delays each heading is moved onto the positions'
        clock when the log is read
        (:func:`~terrain_odom.estimation.time_offset.delay_sensors`).
    """

    pose_delay: float | Literal["auto"] = field(default=0.0, metadata=SIGNED)
    position_delay: float | Literal["auto"] | None = field(default=None, metadata=SIGNED)
    heading_delay: float | Literal["auto"] | None = field(default=None, metadata=SIGNED)

    @property
    def delays(self) -> tuple[float | Literal["auto"], float | Literal["auto"]]:
        """The position and heading delays in effect (``pose_delay`` where not set)."""
        position = self.pose_delay if self.position_delay is None else self.position_delay
        heading = self.pose_delay if self.heading_delay is None else self.heading_delay
        return position, heading


@dataclass(frozen=True)
class ChecksConfig:
    """Plausibility checks of a log before anything is estimated.

    Attributes
    ----------
    enabled : bool
        Compare the wheels with the poses of the log
        (:func:`~terrain_odom.evaluation.plausibility.check_log`) and stop
        with the likely cause where they disagree (default); ``false`` (or
        ``--no-checks``) runs anyway.
    """

    enabled: bool = True


@dataclass(frozen=True)
class PoseSensorConfig:
    """Where the pose sensors sit on the robot (see :mod:`terrain_odom.kinematics.mounting`).

    Attributes
    ----------
    antenna_x, antenna_y : float or "auto"
        Position of the position sensor (GPS antenna) in the robot frame, m
        (x forward, y left, from the reference point whose pose is
        estimated); the measured ``x, y`` are the antenna's. ``auto``:
        estimated from the whole log before the run, by least squares of
        the positions against the wheel path
        (:func:`~terrain_odom.evaluation.calibration.fit_sensors`; needs
        turns of changing sharpness, reported as not observable otherwise).
    heading_offset : float or "auto"
        Measured ``yaw`` minus the robot's yaw, rad (an IMU's mounting, the
        magnetic declination). ``auto``: estimated from the whole log before
        the run, as the circular median over windows of the measured heading
        minus the heading of the path the positions draw
        (:func:`~terrain_odom.evaluation.calibration.fit_sensors`).
    noise : {"config", "auto"}
        ``auto``: estimate each pose sensor's noise from the log (a robust
        scale of its disagreement with short stretches of wheel odometry)
        and use it for ``ekf.sigma_r`` and ``slip_ekf.sigma_r`` where they
        claim less; ``config`` (default): use them as they are.
    heading_bias : bool
        The ICR EKF estimates the heading sensor's slow bias (a consumer
        IMU's wander) as a state: a heading measures ``yaw +
        heading_offset + b``, ``b`` a first-order Gauss-Markov process of
        std ``heading_wander`` and time constant ``wander_time``; then
        ``ekf.sigma_r.yaw`` is the heading's white noise only. It needs
        positions too (only their course tells a slow heading error from
        the yaw); without heading rows it changes no other state. Default
        ``false``: the heading is the robot's yaw plus white noise (a lidar
        or motion-capture pose).
    heading_wander : float
        Stationary std of the heading's bias, rad.
    wander_time : float
        Time constant of the heading's bias, s.
    """

    antenna_x: float | Literal["auto"] = field(default=0.0, metadata=SIGNED)
    antenna_y: float | Literal["auto"] = field(default=0.0, metadata=SIGNED)
    heading_offset: float | Literal["auto"] = field(default=0.0, metadata=SIGNED)
    noise: Literal["config", "auto"] = "config"
    heading_bias: bool = False
    heading_wander: float = 0.17
    wander_time: float = 30.0


@dataclass(frozen=True)
class Config:
    """The whole configuration of a run."""

    format_version: int = FORMAT_VERSION
    robot: RobotConfig = field(default_factory=RobotConfig)
    ekf: EkfConfig = field(default_factory=EkfConfig)
    terrain: TerrainConfig = field(default_factory=TerrainConfig)
    evaluation: EvaluationConfig = field(default_factory=EvaluationConfig)
    slip_ekf: SlipEkfConfig = field(default_factory=SlipEkfConfig)
    time: TimeConfig = field(default_factory=TimeConfig)
    checks: ChecksConfig = field(default_factory=ChecksConfig)
    pose_sensor: PoseSensorConfig = field(default_factory=PoseSensorConfig)
    camera: CameraConfig = field(default_factory=CameraConfig)
    roi: RoiConfig = field(default_factory=RoiConfig)
    classifier: ClassifierConfig = field(default_factory=ClassifierConfig)
