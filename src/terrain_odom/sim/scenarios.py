"""Named simulation scenarios: map, terrain table, driving, sensors, camera.

``chen2023``
    Chen et al. 2023, §4: terrain A (grass), then B (gravel) for about 20 s,
    then A again. The robot slaloms along a straight line (x forward)
    across a gravel band; a brick area off the path gives a third class to
    the training patches.
``mixed``
    Varied arcs over grass, gravel and brick quadrants: a waypoint tour with
    weaving, crossing every terrain several times.

Every scenario has its own camera (a 320 x 240 camera 1 m up, pitched 60
degrees down, so the 1-cm map is sampled at about its resolution) and robot
geometry (track width 0.5 m); ``terrain-odom simulate --config`` replaces
both with the configuration's ``camera`` and ``robot`` sections (the ICRs of
the terrain table scale with the configured track width).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from terrain_odom.config import CameraConfig, RobotConfig
from terrain_odom.errors import ConfigError
from terrain_odom.kinematics import wrap_angle
from terrain_odom.kinematics.mounting import Mounting
from terrain_odom.sim.render import Lighting
from terrain_odom.sim.robot import Driver, TerrainParams
from terrain_odom.sim.world import MapSpec, Region

__all__ = [
    "TERRAIN_TABLE",
    "WeavingDriver",
    "WaypointDriver",
    "Scenario",
    "SCENARIOS",
    "get_scenario",
]

TERRAIN_TABLE: Mapping[str, TerrainParams] = {
    "grass": TerrainParams(y_l=0.42, y_r=-0.40, x_icr=0.05, alpha=0.93),
    "gravel": TerrainParams(y_l=0.60, y_r=-0.58, x_icr=0.10, alpha=0.85),
    "brick": TerrainParams(y_l=0.30, y_r=-0.29, x_icr=0.02, alpha=0.98),
}
"""True ICRs (m) and slip for a 0.5-m-wide robot on each terrain."""

MAX_SIMULATED_ROWS = 5_000_000
"""Most wheel rows a simulation makes (about 28 h at 50 Hz): its arrays live in memory."""

SIM_CAMERA = CameraConfig(
    width=320,
    height=240,
    fx=200.0,
    fy=200.0,
    cx=159.5,
    cy=119.5,
    mount_x=0.3,
    mount_height=1.0,
    mount_pitch=math.radians(60.0),
)
"""Default camera of the scenarios: ground seen from ~0.7 to ~2.2 m ahead."""


def _ramp(t: float, seconds: float = 1.0) -> float:
    return min(1.0, t / seconds)


@dataclass(frozen=True)
class WeavingDriver:
    """Slalom along the world x axis.

    Speed difference ``v_r - v_l = weave * sin(2 pi t / period) - hold * (yaw
    + y / lookahead)`` (m/s, ``yaw`` in rad, ``y`` in m): a sinusoid plus a
    lane keeper towards ``y = 0``; everything ramped up over 1 s. The default
    slalom (+-0.8 m/s every 3 s, yaw swinging about +-20 degrees) turns enough
    for every ICR coordinate to be observable within a couple of seconds; a
    gentle weave (0.12 m/s every 8 s) leaves ``y_l`` and ``y_r`` apart
    poorly observed for 10-20 s after a reset.
    """

    speed: float = 0.5
    weave: float = 0.8
    period: float = 3.0
    hold: float = 0.4
    lookahead: float = 2.0

    def __call__(self, t: float, pose: np.ndarray) -> tuple[float, float]:
        """Wheel speeds (m/s) at time ``t`` (s) for the true ``pose``."""
        turn = self.weave * math.sin(2.0 * math.pi * t / self.period)
        turn -= self.hold * (float(pose[2]) + float(pose[1]) / self.lookahead)
        v, d = self.speed * _ramp(t), 0.5 * turn * _ramp(t)
        return v - d, v + d


@dataclass(frozen=True)
class WaypointDriver:
    """Arcs towards waypoints in turn, plus a weave: varied curvatures.

    The speed difference is ``gain * heading error`` (clipped to
    ``+-max_turn``) plus ``weave * sin(2 pi t / period)``, m/s; a waypoint
    counts as reached within ``reach`` m.
    """

    waypoints: tuple[tuple[float, float], ...]
    speed: float = 0.5
    gain: float = 0.6
    max_turn: float = 0.5
    weave: float = 0.15
    period: float = 6.0
    reach: float = 1.0
    _state: list[int] = field(default_factory=lambda: [0], compare=False, repr=False)

    def __call__(self, t: float, pose: np.ndarray) -> tuple[float, float]:
        """Wheel speeds (m/s) at time ``t`` (s) for the true ``pose``."""
        target = np.asarray(self.waypoints[self._state[0] % len(self.waypoints)])
        if np.hypot(*(target - pose[:2])) < self.reach:
            self._state[0] += 1
            target = np.asarray(self.waypoints[self._state[0] % len(self.waypoints)])
        error = float(wrap_angle(math.atan2(target[1] - pose[1], target[0] - pose[0]) - pose[2]))
        turn = float(np.clip(self.gain * error, -self.max_turn, self.max_turn))
        turn += self.weave * math.sin(2.0 * math.pi * t / self.period)
        v = self.speed * _ramp(t)
        return v - 0.5 * turn * _ramp(t), v + 0.5 * turn * _ramp(t)


@dataclass(frozen=True)
class Scenario:
    """Everything a simulated run is made of.

    Attributes
    ----------
    name, description : str
    map : MapSpec
        Ground map.
    table : mapping of str to TerrainParams
        True parameters per terrain, for ``robot.track_width``.
    driver : object
        Factory (a zero-argument callable) of the wheel-speed schedule.
    start : tuple of 3 float
        Initial pose (m, m, rad).
    duration : float
        s.
    wheel_rate, pose_rate, frame_rate : float
        Hz; ``wheel_rate`` must be a multiple of the other two.
    sigma_encoder : float
        Encoder noise std on each track speed, m/s.
    sigma_xy, sigma_yaw : float
        Pose measurement noise std, m and rad.
    antenna : tuple of 2 float
        Position sensor (GPS antenna) in the robot frame, m: the measured
        ``x, y`` are the antenna's (see ``pose_sensor`` in the configuration).
    heading_offset : float
        Measured heading minus the true yaw, rad (an IMU's mounting).
    camera : CameraConfig
    robot : RobotConfig
    lighting : Lighting
        Lighting change and sensor noise (its ``phase`` is drawn per seed).
    patch_size : int
        Side of the training patches, px.
    patches_per_terrain : int
    patch_margin : float
        Patches see no ground closer than this to the driven path, m.
    """

    name: str
    description: str
    map: MapSpec
    driver: object
    table: Mapping[str, TerrainParams] = field(default_factory=lambda: dict(TERRAIN_TABLE))
    start: tuple[float, float, float] = (0.0, 0.0, 0.0)
    duration: float = 60.0
    wheel_rate: float = 50.0
    pose_rate: float = 10.0
    frame_rate: float = 10.0
    sigma_encoder: float = 0.01
    sigma_xy: float = 0.02
    sigma_yaw: float = 0.01
    antenna: tuple[float, float] = (0.0, 0.0)
    heading_offset: float = 0.0
    camera: CameraConfig = SIM_CAMERA
    robot: RobotConfig = field(default_factory=lambda: RobotConfig(track_width=0.5))
    lighting: Lighting = field(default_factory=Lighting)
    patch_size: int = 96
    patches_per_terrain: int = 40
    patch_margin: float = 1.0

    def __post_init__(self) -> None:
        rows = self.duration * self.wheel_rate
        if not rows <= MAX_SIMULATED_ROWS:
            hours = MAX_SIMULATED_ROWS / self.wheel_rate / 3600.0
            raise ConfigError(
                f"duration: {self.duration:g} s at {self.wheel_rate:g} Hz is {rows:.3g} rows, more "
                f"than the {MAX_SIMULATED_ROWS:,} a simulation holds in memory: at most "
                f"{hours:.1f} h; simulate shorter runs"
            )
        for name, rate in (("pose_rate", self.pose_rate), ("frame_rate", self.frame_rate)):
            ratio = self.wheel_rate / rate if rate > 0 else 0.0
            if not (ratio >= 1.0 and abs(ratio - round(ratio)) < 1e-9):
                raise ConfigError(
                    f"{name}: wheel_rate {self.wheel_rate} Hz must be a multiple of it ({rate} Hz)"
                )

    @property
    def mounting(self) -> Mounting:
        """The pose sensors' mounting (antenna, heading offset)."""
        return Mounting(*self.antenna, self.heading_offset)

    def make_driver(self) -> Driver:
        """Return a fresh wheel-speed schedule (drivers may keep state)."""
        return self.driver()  # type: ignore[operator]


def _box(x0: float, x1: float, y0: float, y1: float) -> tuple[tuple[float, float], ...]:
    return ((x0, y0), (x1, y0), (x1, y1), (x0, y1))


def _chen2023() -> Scenario:
    # Grass until x = 8 m (~17 s at 0.465 m/s), gravel for 8.5 m (~20 s at
    # 0.425 m/s), then grass again; brick off the path for training patches.
    spec = MapSpec(
        extent=(-4.0, 34.0, -7.0, 7.0),
        resolution=0.01,
        base="grass",
        regions=(
            Region("gravel", _box(8.0, 16.5, -7.0, 7.0)),
            Region("brick", _box(20.0, 34.0, 3.0, 7.0)),
        ),
    )
    return Scenario(
        name="chen2023",
        description="Chen et al. 2023 §4: grass, then gravel for ~20 s, then grass",
        map=spec,
        driver=WeavingDriver,
    )


def _mixed() -> Scenario:
    spec = MapSpec(
        extent=(-12.0, 12.0, -12.0, 12.0),
        resolution=0.01,
        base="grass",
        regions=(
            Region("gravel", _box(0.0, 12.0, -12.0, 0.0)),
            Region("brick", _box(-12.0, 0.0, -12.0, -3.0)),
        ),
    )
    tour = ((-5.0, -7.0), (6.0, -6.0), (6.0, 5.0), (-6.0, 6.0))

    def driver() -> WaypointDriver:
        return WaypointDriver(waypoints=tour)

    return Scenario(
        name="mixed",
        description="varied arcs over grass, gravel and brick quadrants",
        map=spec,
        driver=driver,
        start=(-4.0, 2.0, -math.pi / 2),
        duration=90.0,
    )


SCENARIOS = {"chen2023": _chen2023, "mixed": _mixed}
"""Scenario name -> factory."""


def get_scenario(name: str) -> Scenario:
    """Return the scenario called ``name``.

    Raises
    ------
    ConfigError
        If there is no such scenario (the message lists the known ones).
    """
    try:
        return SCENARIOS[name]()
    except KeyError:
        known = ", ".join(sorted(SCENARIOS))
        raise ConfigError(f"unknown scenario {name!r} (known: {known})") from None
