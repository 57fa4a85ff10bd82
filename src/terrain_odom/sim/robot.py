"""Simulated skid-steer robot: true motion, encoder noise, GPS-like poses.

The true motion is the ICR model with longitudinal slip
(:func:`terrain_odom.kinematics.twist_icr`) whose parameters are those of the
terrain under the robot origin at the start of each wheel sample; each
sample's twist is held for the sample period and integrated exactly
(:func:`terrain_odom.kinematics.arc_increment`). Row ``k``'s speeds are held
from ``t[k]`` to ``t[k+1]``, as in the wheel-log format.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from terrain_odom.errors import ConfigError
from terrain_odom.kinematics import arc_increment, compose, twist_icr, wrap_angle
from terrain_odom.kinematics.mounting import Mounting, sensor_pose
from terrain_odom.sim.world import GroundMap

__all__ = ["TerrainParams", "Driver", "Motion", "drive", "encoder_speeds", "pose_measurements"]

Driver = Callable[[float, np.ndarray], tuple[float, float]]
"""``(t, true pose) -> (v_l, v_r)``: the wheel-speed schedule (m/s)."""


@dataclass(frozen=True)
class TerrainParams:
    """True kinematic parameters of a terrain.

    Attributes
    ----------
    y_l, y_r : float
        Lateral coordinates of the left and right track ICRs, m (``y_l > y_r``).
    x_icr : float
        Forward coordinate of the ICRs, m.
    alpha : float
        Longitudinal slip factor (1 = none).
    """

    y_l: float
    y_r: float
    x_icr: float
    alpha: float

    def scaled(self, factor: float) -> TerrainParams:
        """Return the same terrain for a robot ``factor`` times larger (ICRs scale, alpha not)."""
        return TerrainParams(self.y_l * factor, self.y_r * factor, self.x_icr * factor, self.alpha)


@dataclass(frozen=True)
class Motion:
    """True motion at every wheel sample.

    Attributes
    ----------
    t : ndarray, shape (N,)
        Time, s.
    v_l, v_r : ndarray, shape (N,)
        True (noise-free) track speeds held from ``t[k]`` to ``t[k+1]``, m/s.
    pose : ndarray, shape (N, 3)
        True pose ``x, y, yaw`` at ``t[k]`` (m, m, rad).
    params : ndarray, shape (N, 4)
        ``y_l, y_r, x_icr, alpha`` used from ``t[k]`` to ``t[k+1]``.
    terrain : ndarray of str, shape (N,)
        Terrain under the robot origin at ``t[k]``.
    """

    t: np.ndarray
    v_l: np.ndarray
    v_r: np.ndarray
    pose: np.ndarray
    params: np.ndarray
    terrain: np.ndarray


def drive(
    ground: GroundMap,
    table: Mapping[str, TerrainParams],
    driver: Driver,
    *,
    duration: float,
    rate: float,
    start: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> Motion:
    """Drive the robot over the map for ``duration`` seconds.

    Parameters
    ----------
    ground : GroundMap
        Terrain lookup.
    table : mapping of str to TerrainParams
        True parameters of every terrain of the map.
    driver : Driver
        Wheel-speed schedule, called once per sample with the true pose.
    duration : float
        s; samples at ``t = k / rate`` for ``t < duration``.
    rate : float
        Wheel sample rate, Hz.
    start : tuple of 3 float
        Initial pose (m, m, rad).

    Returns
    -------
    Motion

    Raises
    ------
    ConfigError
        The robot leaves the map (the duration is too long for it).
    ValueError
        It meets a terrain missing from ``table``.
    """
    n = int(np.ceil(duration * rate - 1e-9))
    t = np.arange(n) / rate
    pose = np.empty((n, 3))
    params = np.empty((n, 4))
    speeds = np.empty((n, 2))
    terrain = np.empty(n, dtype=object)
    current = np.asarray(start, dtype=float)
    for k in range(n):
        name = str(ground.terrain_at(current[:2]))
        if name == "":
            raise ConfigError(
                f"duration: the robot leaves the scenario's map at t = {t[k]:.2f} s (x, y = "
                f"{current[0]:.1f}, {current[1]:.1f} m); simulate at most {t[k]:.0f} s of it"
            )
        if name not in table:
            raise ValueError(f"terrain {name!r} has no kinematic parameters")
        p = table[name]
        pose[k], terrain[k] = current, name
        params[k] = (p.y_l, p.y_r, p.x_icr, p.alpha)
        speeds[k] = driver(float(t[k]), current.copy())
        twist = twist_icr(speeds[k, 0], speeds[k, 1], *params[k])
        current = compose(current, arc_increment(*twist, 1.0 / rate))
    return Motion(t, speeds[:, 0], speeds[:, 1], pose, params, terrain.astype(str))


def encoder_speeds(
    motion: Motion, sigma: float, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """Measured track speeds: the true ones plus white noise of std ``sigma`` (m/s)."""
    noise = rng.normal(0.0, sigma, (2, motion.t.size))
    return motion.v_l + noise[0], motion.v_r + noise[1]


def pose_measurements(
    motion: Motion,
    every: int,
    sigma_xy: float,
    sigma_yaw: float,
    rng: np.random.Generator,
    mounting: Mounting | None = None,
) -> np.ndarray:
    """GPS-like poses on every ``every``-th sample (from the first), NaN elsewhere.

    Parameters
    ----------
    motion : Motion
        True motion.
    every : int
        Samples between measurements (wheel rate / pose rate).
    sigma_xy, sigma_yaw : float
        Noise std of the position (m) and heading (rad).
    rng : numpy.random.Generator
    mounting : Mounting, optional
        Antenna lever arm and heading offset: the antenna's position and the
        sensor's heading are measured (the robot's own pose by default).

    Returns
    -------
    ndarray, shape (N, 3)
        ``x, y, yaw`` (m, m, rad), yaw wrapped; NaN rows without a measurement.
    """
    measured = np.full_like(motion.pose, np.nan)
    rows = np.arange(0, motion.t.size, every)
    noise = rng.normal(0.0, 1.0, (rows.size, 3)) * (sigma_xy, sigma_xy, sigma_yaw)
    sensor = motion.pose[rows]
    if mounting is not None and mounting != Mounting():
        sensor = np.array([sensor_pose(pose, mounting) for pose in sensor]).reshape(-1, 3)
    measured[rows] = sensor + noise
    measured[rows, 2] = wrap_angle(measured[rows, 2])
    return measured
