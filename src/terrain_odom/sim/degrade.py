"""Realistic GPS and IMU streams from a log whose poses are the truth.

A consumer robot does not have a total station: it has a GPS antenna
somewhere on its roof (fixes at a few hertz, noise of most of a metre, a
bias that wanders, a latency nobody measured) and an IMU whose heading is
mounted at some angle and disturbed by whatever metal drives past. To
develop and test the estimators on that, :func:`degrade_log` turns a clean
log (the real Warthog logs with their lidar ICP poses, or a simulated run's
true poses) into such a recording, keeping the clean log as the truth.

The true pose at any instant is interpolated between the clean log's pose
rows (linearly in ``x, y`` and in the unwrapped ``yaw``). A GPS fix stamped
``t`` measures the antenna at ``t - latency``::

    x, y = p(t - latency) + R(yaw) a + b(t) + n,   n ~ N(0, gps_noise^2 I)

with ``a`` the antenna in the robot frame and ``b`` a random walk
(``gps_walk`` m/sqrt(s) per axis, starting at 0 on each run). An IMU
heading stamped ``t`` measures::

    yaw_imu = yaw(t - imu_latency) + heading_offset + w(t) + n

with ``w`` a slowly varying disturbance (an Ornstein-Uhlenbeck process:
stationary std ``heading_wander``, time constant ``wander_time``) and ``n``
white noise (``heading_noise``). The output has the clean log's wheel rows
(their poses removed) and one row per fix and per heading, with the wheel
speeds held from the previous wheel row; a fix or heading within 1 us of a
wheel row is put on that row.

Examples
--------
>>> import numpy as np
>>> from terrain_odom.records import WheelLog
>>> t = np.arange(0.0, 20.0, 0.05)
>>> truth = np.column_stack([0.5 * t, np.zeros_like(t), np.zeros_like(t)])
>>> clean = WheelLog(t, np.full(t.size, 0.5), np.full(t.size, 0.5), truth, None,
...                  np.zeros(t.size, int))
>>> out = degrade_log(clean, Degradation(gps_noise=0.0, gps_walk=0.0, latency=0.0,
...                                      antenna=(0.0, 0.0), heading_offset=0.0,
...                                      heading_wander=0.0, heading_noise=0.0, seed=1))
>>> fixes, headings = out.log.t[out.log.has_position], out.log.t[out.log.has_yaw]
>>> float(np.diff(fixes).round(6).max()), float(np.diff(headings).round(6).max())  # 2.5 and 50 Hz
(0.4, 0.02)
>>> bool(np.allclose(out.log.pose[out.log.has_position, 0],
...                  0.5 * out.log.t[out.log.has_position]))
True
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.kinematics.integration import wrap_angle
from terrain_odom.kinematics.mounting import Mounting, sensor_pose
from terrain_odom.records import WheelLog

__all__ = ["Degradation", "DegradedLog", "degrade_log"]

_SAME_ROW = 1e-6
"""Stamps closer than this (s) to a wheel row are put on that row."""


@dataclass(frozen=True)
class Degradation:
    """What a consumer GPS and IMU do to the true poses.

    Attributes
    ----------
    gps_rate : float
        GPS fixes per second, Hz; 0: no GPS rows.
    gps_noise : float
        White noise of each fix, m (std per axis).
    gps_walk : float
        Random-walk bias of the fixes, m/sqrt(s) per axis.
    latency : float
        GPS latency, s: a fix stamped ``t`` was measured at ``t - latency``.
    antenna : tuple of float
        GPS antenna in the robot frame, m (x forward, y left).
    gps_claimed : float or None
        The position std a driver's message covariance would claim, m
        (default: ``gps_noise``, the white part only).
    imu_rate : float
        IMU headings per second, Hz; 0: no heading rows.
    heading_offset : float
        IMU heading minus the robot's yaw, rad (its mounting).
    heading_wander : float
        Stationary std of the slow heading disturbance, rad.
    wander_time : float
        Time constant of the disturbance, s.
    heading_noise : float
        White noise of each heading, rad.
    heading_claimed : float
        The heading std the IMU's message covariance claims, rad.
    imu_latency : float
        IMU latency, s.
    seed : int
        Seed of the noise; the same seed gives the same recording.
    """

    gps_rate: float = 2.5
    gps_noise: float = 0.8
    gps_walk: float = 0.05
    latency: float = 0.5
    antenna: tuple[float, float] = (-1.0, 0.0)
    gps_claimed: float | None = None
    imu_rate: float = 50.0
    heading_offset: float = 2.7
    heading_wander: float = 0.26
    wander_time: float = 30.0
    heading_noise: float = 0.02
    heading_claimed: float = 0.035
    imu_latency: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        for name in (
            "gps_rate",
            "gps_noise",
            "gps_walk",
            "latency",
            "imu_rate",
            "heading_wander",
            "heading_noise",
            "heading_claimed",
            "imu_latency",
        ):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0.0):
                raise ConfigError(f"degradation: {name} must be finite and >= 0, got {value}")
        if not (np.isfinite(self.wander_time) and self.wander_time > 0.0):
            raise ConfigError(f"degradation: wander_time must be > 0 s, got {self.wander_time}")
        if not abs(self.heading_offset) <= np.pi:
            raise ConfigError(
                f"degradation: heading_offset is radians within +-pi, got {self.heading_offset}"
            )
        if len(self.antenna) != 2 or not np.all(np.isfinite(self.antenna)):
            raise ConfigError(f"degradation: antenna must be two finite metres, got {self.antenna}")

    @property
    def mounting(self) -> Mounting:
        """The antenna and heading offset as the estimators' :class:`Mounting`."""
        return Mounting(float(self.antenna[0]), float(self.antenna[1]), self.heading_offset)

    def injected(self) -> dict[str, Any]:
        """Return every injected value by name (plain floats; for ``degrade.yaml`` and tests)."""
        values = dataclasses.asdict(self)
        values.pop("antenna")
        values["antenna_x"], values["antenna_y"] = (float(a) for a in self.antenna)
        if self.gps_claimed is None:
            values["gps_claimed"] = self.gps_noise
        return values


@dataclass(frozen=True)
class DegradedLog:
    """A degraded recording and its truth.

    Attributes
    ----------
    log : WheelLog
        Wheel rows, GPS rows (``x, y``) and IMU rows (``yaw``), time-sorted.
    truth : WheelLog
        The clean input, unchanged: its pose rows are the truth.
    injected : dict
        :meth:`Degradation.injected`.
    """

    log: WheelLog
    truth: WheelLog
    injected: dict[str, Any]


def degrade_log(clean: WheelLog, degradation: Degradation) -> DegradedLog:
    """Return a GPS + IMU recording made from ``clean``'s true poses.

    Parameters
    ----------
    clean : WheelLog
        Track speeds (m/s) and true poses on some rows (full ``x, y, yaw``);
        each run (segment) is degraded on its own, over the span its poses
        cover.
    degradation : Degradation
        What to inject.

    Returns
    -------
    DegradedLog

    Raises
    ------
    InputFileError
        No run of ``clean`` has two full poses to interpolate between.
    """
    rng = np.random.default_rng(degradation.seed)
    parts = [
        _degrade_run(clean.take(np.asarray(rows)), degradation, rng)
        for rows in clean.run_ranges()
        if int(clean.take(np.asarray(rows)).has_pose.sum()) >= 2
    ]
    if not parts:
        raise InputFileError(
            f"{clean.source}: no run with two full poses (x, y, yaw) to degrade: "
            "the truth is interpolated between them"
        )
    labels = [p.terrain for p in parts if p.terrain is not None]
    log = WheelLog(
        np.concatenate([p.t for p in parts]),
        np.concatenate([p.v_l for p in parts]),
        np.concatenate([p.v_r for p in parts]),
        np.concatenate([p.pose for p in parts]),
        np.concatenate(labels) if clean.terrain is not None else None,
        np.concatenate([p.segment for p in parts]),
        f"{clean.source} (degraded, seed {degradation.seed})",
    )
    return DegradedLog(log, clean, degradation.injected())


def _degrade_run(run: WheelLog, d: Degradation, rng: np.random.Generator) -> WheelLog:
    """Degrade one run (one segment, at least two full poses)."""
    truth_t, truth_pose = run.t[run.has_pose], run.pose[run.has_pose]
    yaw_unwrapped = np.unwrap(truth_pose[:, 2])
    t0, t1 = float(run.t[0]), float(run.t[-1])

    def true_pose(at: np.ndarray) -> np.ndarray:
        return np.column_stack(
            [
                np.interp(at, truth_t, truth_pose[:, 0]),
                np.interp(at, truth_t, truth_pose[:, 1]),
                wrap_angle(np.interp(at, truth_t, yaw_unwrapped)),
            ]
        )

    def stamps(rate: float, latency: float) -> np.ndarray:
        if rate <= 0.0:
            return np.empty(0)
        t = t0 + rng.uniform(0.0, 1.0 / rate) + np.arange(0.0, t1 - t0, 1.0 / rate)
        t = np.round(t[t <= t1], 6)
        return t[(t - latency >= truth_t[0]) & (t - latency <= truth_t[-1])]

    gps_t = stamps(d.gps_rate, d.latency)
    imu_t = stamps(d.imu_rate, d.imu_latency)
    fixes = _fixes(true_pose(gps_t - d.latency), gps_t, d, rng)
    headings = _headings(true_pose(imu_t - d.imu_latency)[:, 2], imu_t, d, rng)
    return _merged(run, gps_t, fixes, imu_t, headings)


def _fixes(pose: np.ndarray, t: np.ndarray, d: Degradation, rng: np.random.Generator) -> np.ndarray:
    """Antenna positions with white noise and a random-walk bias, shape (n, 2)."""
    if t.size == 0:
        return np.empty((0, 2))
    antenna = np.array([sensor_pose(p, d.mounting)[:2] for p in pose]).reshape(-1, 2)
    steps = (
        rng.normal(0.0, 1.0, (t.size, 2)) * d.gps_walk * np.sqrt(np.diff(t, prepend=t[0]))[:, None]
    )
    white = rng.normal(0.0, d.gps_noise, (t.size, 2))
    return antenna + np.cumsum(steps, axis=0) + white


def _headings(
    yaw: np.ndarray, t: np.ndarray, d: Degradation, rng: np.random.Generator
) -> np.ndarray:
    """IMU headings: yaw + offset + Ornstein-Uhlenbeck disturbance + white noise, wrapped."""
    if t.size == 0:
        return np.empty(0)
    decay = np.exp(-np.diff(t, prepend=t[0]) / d.wander_time)
    kicks = rng.normal(0.0, 1.0, t.size) * d.heading_wander * np.sqrt(1.0 - decay**2)
    kicks[0] = rng.normal(0.0, d.heading_wander)
    wander = np.empty(t.size)
    level = 0.0
    for k in range(t.size):  # a first-order recursion: O(n), 50 Hz over an hour is 180k steps
        level = decay[k] * level + kicks[k]
        wander[k] = level
    white = rng.normal(0.0, d.heading_noise, t.size)
    return wrap_angle(yaw + d.heading_offset + wander + white)


def _merged(
    run: WheelLog, gps_t: np.ndarray, fixes: np.ndarray, imu_t: np.ndarray, headings: np.ndarray
) -> WheelLog:
    """Merge the run's wheel rows (poses removed) with the fix and heading rows."""
    t = np.unique(np.concatenate([run.t, gps_t, imu_t]))
    # stamps within 1 us of an earlier time collapse onto it (np.unique keeps exact ties only)
    keep = np.concatenate([[True], np.diff(t) > _SAME_ROW])
    t = t[keep]
    pose = np.full((t.size, 3), np.nan)
    pose[_row_of(t, gps_t), :2] = fixes
    pose[_row_of(t, imu_t), 2] = headings
    wheel = np.searchsorted(run.t, t + _SAME_ROW, side="right") - 1
    return WheelLog(
        t,
        run.v_l[wheel],
        run.v_r[wheel],
        pose,
        None if run.terrain is None else run.terrain[wheel],
        run.segment[wheel],
        run.source,
    )


def _row_of(t: np.ndarray, stamps: np.ndarray) -> np.ndarray:
    """Index of the row of ``t`` (merged times) that each stamp landed on."""
    return np.searchsorted(t, stamps + _SAME_ROW, side="right") - 1
