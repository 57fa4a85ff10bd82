"""The live odometry's output: the body twist's covariance from the ICRs'."""

from __future__ import annotations

import numpy as np

from terrain_odom.app.live.output import twist_with_covariance
from terrain_odom.kinematics.models import twist_icr


def test_twist_covariance_matches_sampling() -> None:
    names = ("x", "y", "yaw", "y_l", "y_r", "x_icr", "alpha")
    state = np.array([0.0, 0.0, 0.0, 0.6, -0.55, 0.1, 0.9])
    std = np.array([0.0, 0.0, 0.0, 0.02, 0.03, 0.05, 0.02])
    twist, cov = twist_with_covariance(0.4, 1.2, names, state, std)
    rng = np.random.default_rng(0)
    params = state[3:] + std[3:] * rng.standard_normal((200_000, 4))
    samples = np.array(twist_icr(0.4, 1.2, *params.T)).T
    np.testing.assert_allclose(twist, samples.mean(axis=0), atol=2e-3)
    np.testing.assert_allclose(cov, np.cov(samples.T), rtol=0.05, atol=1e-6)
