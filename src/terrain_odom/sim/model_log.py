"""Wheel logs driven by a known constant kinematic model (for identification studies).

:func:`constant_model_log` drives random piecewise-constant track speeds
through any model of :mod:`terrain_odom.kinematics.models` with known
parameters and measures the exactly integrated pose with Gaussian noise, so
a fit (:mod:`terrain_odom.fitting`) can be checked against the truth.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from terrain_odom.kinematics import get_model, integrate
from terrain_odom.records import WheelLog

__all__ = ["RATE", "POSE_EVERY", "POSE_NOISE", "constant_model_log"]

RATE = 20.0  # Hz, wheel rows
POSE_EVERY = 2  # a pose measurement every 2nd row (10 Hz)
POSE_NOISE = (0.003, 0.003, 0.002)  # m, m, rad: standard deviations of the measured poses


def constant_model_log(
    model: str,
    params: ArrayLike,
    *,
    seconds: float = 120.0,
    seed: int = 0,
    track_width: float = 1.0,
    noise: Sequence[float] = POSE_NOISE,
    terrain: str | None = None,
    segments: int = 1,
) -> WheelLog:
    """Simulate a log of random piecewise-constant track speeds driven by ``model``.

    Speeds change every 0.5 s (forward 0.3-1.5 m/s with turns of either sign
    and a few spins); the true poses are integrated exactly and measured every
    ``POSE_EVERY`` rows with Gaussian ``noise``. With ``segments > 1`` the log
    is cut into that many equal segments, each starting again at the origin.

    Parameters
    ----------
    model : str
        Model name (:func:`~terrain_odom.kinematics.get_model`).
    params : array_like, shape (k,)
        True parameters in the model's ``param_names`` order.
    seconds : float
        Duration, s (``RATE`` rows per second).
    seed : int
        Seed of the speeds and the pose noise.
    track_width : float
        Nominal track width ``B``, m, for models that need it.
    noise : sequence of 3 float
        Standard deviations of the measured ``x, y, yaw`` (m, m, rad).
    terrain : str, optional
        Terrain label of every row (no terrain column if omitted).
    segments : int
        Number of equal segments.

    Returns
    -------
    WheelLog
        Source ``"<sim MODEL>"``.

    Examples
    --------
    >>> log = constant_model_log("edd-sym", [0.9, 1.8], seconds=1.0, segments=2)
    >>> len(log), log.n_runs, int(log.has_pose.sum())
    (20, 2, 10)
    """
    rng = np.random.default_rng(seed)
    n = int(seconds * RATE)
    hold = int(0.5 * RATE)
    n_cmd = -(-n // hold)
    forward = rng.uniform(0.3, 1.5, n_cmd)
    turn = rng.uniform(-1.0, 1.0, n_cmd) * rng.choice([0.2, 0.6, 1.2], n_cmd)
    v_l = np.repeat(forward - turn, hold)[:n]
    v_r = np.repeat(forward + turn, hold)[:n]
    t = np.arange(n) / RATE
    seg = np.repeat(np.arange(segments), -(-n // segments))[:n]
    v_x, v_y, omega = get_model(model).twist(v_l, v_r, np.asarray(params, float), track_width)
    pose = np.full((n, 3), np.nan)
    for s in range(segments):
        rows = np.flatnonzero(seg == s)
        dt = np.diff(t[rows])
        k = rows[:-1]
        truth = integrate(v_x[k], v_y[k], omega[k], dt)
        measured = np.arange(0, rows.size, POSE_EVERY)
        pose[rows[measured]] = truth[measured] + rng.normal(0.0, noise, (measured.size, 3))
    labels = None if terrain is None else np.full(n, terrain)
    return WheelLog(t, v_l, v_r, pose, labels, seg, f"<sim {model}>")
