"""Simulated logs for the slip-parameter EKF (the 2016 paper's Sec. 4).

Two scenarios on a tracked vehicle of track width 2.46 m (the paper's
vehicle; no-slip ICRs at +-1.23 m):

- :func:`icr_switch_scenario` (Sec. 4.1): 2 s straight at 2 m/s, then the
  right track slows to 1 m/s and the ICRs jump from ``(1.23, -1.23, 0)`` to
  ``(2.23, -2.23, 0.5)`` m (terrain ``B``), as in the paper; at 12 s they
  jump back to the no-slip values (terrain ``C``) while the vehicle keeps
  turning. The paper does not say how it drives after 12 s; a straight
  drive would make that change trivial for the slip model (zero features
  give ``y = +-B/2`` whatever the parameters), so the turn goes on. Pose at
  10 Hz and wheels at 100 Hz, as in the paper's experiment (Sec. 5.1); pose
  noise as for RTK GPS with an IMU heading (2 cm, 0.5 deg by default; the
  paper's values were lost).
- :func:`feature_slip_scenario` (Sec. 4.2): random piecewise-constant track
  speeds whose true ICRs follow the slip model with known parameters;
  pose at 1 Hz, wheels at 10 Hz.

The true pose integrates the ICR twist exactly (arcs); the pose
measurements are the true pose plus Gaussian noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from terrain_odom.config import IcrLimits
from terrain_odom.kinematics import integrate, twist_icr, wrap_angle
from terrain_odom.kinematics.slip import SlipModel
from terrain_odom.records import WheelLog

__all__ = [
    "TRACK_WIDTH",
    "SlipScenario",
    "simulate_log",
    "icr_switch_scenario",
    "feature_slip_scenario",
]

TRACK_WIDTH = 2.46  # m, the 2016 paper's vehicle (2.464 m)


@dataclass(frozen=True)
class SlipScenario:
    """A simulated log with its ground truth.

    Attributes
    ----------
    log : WheelLog
        Track speeds at every row, noisy pose on the measurement rows.
    icr : ndarray, shape (N, 3)
        True ``y_l, y_r, x_icr`` per row, m.
    pose : ndarray, shape (N, 3)
        True pose per row.
    changes : tuple of float
        Times of the abrupt ICR changes, s.
    """

    log: WheelLog
    icr: np.ndarray
    pose: np.ndarray
    changes: tuple[float, ...] = ()


def simulate_log(
    t: ArrayLike,
    v_l: ArrayLike,
    v_r: ArrayLike,
    icr: ArrayLike,
    *,
    pose_every: int,
    sigma_xy: float = 0.02,
    sigma_yaw: float = 0.0087,
    terrain: ArrayLike | None = None,
    seed: int = 0,
) -> SlipScenario:
    """Integrate the ICR model over the rows and sample noisy poses.

    Parameters
    ----------
    t, v_l, v_r : array_like, shape (N,)
        Row times (s) and track speeds (m/s), held until the next row.
    icr : array_like, shape (N, 3)
        True ``y_l, y_r, x_icr`` per row, m.
    pose_every : int
        A pose measurement on every ``pose_every``-th row (from row 0).
    sigma_xy, sigma_yaw : float
        Measurement noise, m and rad.
    terrain : array_like of str, shape (N,), optional
        Terrain label per row.
    seed : int
        Seed of the noise.

    Returns
    -------
    SlipScenario
    """
    t, v_l, v_r = (np.asarray(a, dtype=float) for a in (t, v_l, v_r))
    icr = np.asarray(icr, dtype=float)
    twist = twist_icr(v_l, v_r, icr[:, 0], icr[:, 1], icr[:, 2])
    dt = np.append(np.diff(t), 0.0)
    truth = integrate(*twist, dt)[:-1]
    rng = np.random.default_rng(seed)
    pose = np.full_like(truth, np.nan)
    rows = np.arange(0, t.size, pose_every)
    noise = rng.normal(size=(rows.size, 3)) * [sigma_xy, sigma_xy, sigma_yaw]
    pose[rows] = truth[rows] + noise
    pose[rows, 2] = wrap_angle(pose[rows, 2])
    labels = None if terrain is None else np.asarray(terrain, dtype=str)
    log = WheelLog(t, v_l, v_r, pose, labels, np.zeros(t.size, dtype=np.int64), "<simulated>")
    return SlipScenario(log, icr, truth)


def icr_switch_scenario(
    *,
    wheel_rate: float = 100.0,
    pose_rate: float = 10.0,
    duration: float = 22.0,
    sigma_xy: float = 0.02,
    sigma_yaw: float = 0.0087,
    seed: int = 0,
) -> SlipScenario:
    """Simulate the paper's Sec. 4.1 abrupt ICR change (see the module docstring).

    Parameters
    ----------
    wheel_rate, pose_rate : float
        Row rate and pose measurement rate, Hz (``wheel_rate / pose_rate``
        must be a whole number).
    duration : float
        Length, s (> 12).
    sigma_xy, sigma_yaw : float
        Pose measurement noise, m and rad.
    seed : int
        Seed of the pose noise.
    """
    t = np.arange(0.0, duration, 1.0 / wheel_rate)
    turning = t >= 2.0
    v_l = np.full(t.size, 2.0)
    v_r = np.where(turning, 1.0, 2.0)
    half = 0.5 * TRACK_WIDTH
    slip = turning & (t < 12.0)
    icr = np.where(slip[:, None], [half + 1.0, -half - 1.0, 0.5], [half, -half, 0.0])
    terrain = np.where(t < 2.0, "A", np.where(slip, "B", "C"))
    every = int(round(wheel_rate / pose_rate))
    scenario = simulate_log(
        t, v_l, v_r, icr, pose_every=every, sigma_xy=sigma_xy, sigma_yaw=sigma_yaw,
        terrain=terrain, seed=seed,
    )  # fmt: skip
    return SlipScenario(scenario.log, scenario.icr, scenario.pose, (2.0, 12.0))


def feature_slip_scenario(
    params: ArrayLike,
    *,
    duration: float = 120.0,
    wheel_rate: float = 10.0,
    pose_rate: float = 1.0,
    seed: int = 0,
) -> SlipScenario:
    """Random driving whose true ICRs follow the slip model with ``params``.

    Track speeds are piecewise constant over 2-6 s pieces: forward speed in
    [0.5, 2] m/s and speed difference in [-2, 2] m/s (a third of the pieces
    straight).

    Parameters
    ----------
    params : array_like, shape (6,)
        True ``l1 .. l6``.
    duration : float
        Length, s.
    wheel_rate, pose_rate : float
        Row rate and pose measurement rate, Hz.
    seed : int
        Seed of the speeds and the noise.
    """
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration, 1.0 / wheel_rate)
    v = np.empty(t.size)
    diff = np.empty(t.size)
    first = 0
    while first < t.size:
        last = first + int(rng.uniform(2.0, 6.0) * wheel_rate)
        v[first:last] = rng.uniform(0.5, 2.0)
        diff[first:last] = 0.0 if rng.random() < 1 / 3 else rng.uniform(-2.0, 2.0)
        first = last
    v_l, v_r = v - 0.5 * diff, v + 0.5 * diff
    model = SlipModel(TRACK_WIDTH, 1e-3, True, True, IcrLimits())
    icr = np.stack(model.icrs(np.asarray(params, dtype=float), *model.features(v_l, v_r)), axis=1)
    every = int(round(wheel_rate / pose_rate))
    return simulate_log(t, v_l, v_r, icr, pose_every=every, seed=seed + 1)
