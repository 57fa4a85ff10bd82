"""The identification loss with a full covariance, and its yaw error wrapped.

Mutation testing found two changes no test noticed: the whitener applied
transposed (the same for a diagonal Sigma, the only kind tested) and the
end-of-segment yaw error left unwrapped.
"""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.fitting import Horizon, residuals, segment_set, training_windows
from terrain_odom.fitting.loss import squared_loss, whitener_matrix
from terrain_odom.kinematics import get_model, integrate, wrap_angle
from terrain_odom.records import WheelLog
from terrain_odom.sim.model_log import constant_model_log

# Sigma with a correlated x-y block, chosen so that inv(Sigma) = [[2, 1, 0], [1, 1, 0], [0, 0, 4]]:
# e^T inv(Sigma) e = 2 e_x^2 + 2 e_x e_y + e_y^2 + 4 e_yaw^2 = e_x^2 + (e_x + e_y)^2 + (2 e_yaw)^2
SIGMA = np.array([[1.0, -1.0, 0.0], [-1.0, 2.0, 0.0], [0.0, 0.0, 0.25]])


def _by_hand(e: np.ndarray) -> np.ndarray:
    """Return ``e^T inv(SIGMA) e`` per error vector (last axis ``dx, dy, dyaw``), written out."""
    return e[..., 0] ** 2 + (e[..., 0] + e[..., 1]) ** 2 + (2.0 * e[..., 2]) ** 2


def test_whitener_of_a_full_sigma_gives_the_mahalanobis_norm_of_a_hand_error():
    low = whitener_matrix(SIGMA)
    np.testing.assert_allclose(low @ low.T, np.linalg.inv(SIGMA), atol=1e-12)
    e = np.array([0.3, -0.5, 0.1])
    whitened = e @ low  # the row-vector form residuals() uses: (L^T e)^T
    assert float(whitened @ whitened) == pytest.approx(0.09 + 0.04 + 0.04, abs=1e-12)
    assert float(whitened @ whitened) == pytest.approx(float(_by_hand(e)), abs=1e-12)


def test_full_sigma_loss_of_each_segment_is_its_mahalanobis_norm():
    segs = segment_set(
        [log := constant_model_log("edd-sym", [0.9, 1.8], seconds=30.0, seed=3)],
        [training_windows(log, Horizon(2.0, "m"))],
    )
    model = get_model("edd-sym")
    params = np.array([[0.8, 2.1], [1.0, 1.5]])  # wrong parameters: errors in x, y and yaw
    raw = residuals(model, params, segs)
    white = residuals(model, params, segs, whitener=whitener_matrix(SIGMA))
    assert np.all(np.abs(raw).max(axis=1) > 1e-3)  # every component of the error is exercised
    np.testing.assert_allclose(np.sum(white**2, axis=-1), _by_hand(raw), rtol=1e-10)
    np.testing.assert_allclose(squared_loss(white), _by_hand(raw).sum(axis=1), rtol=1e-10)
    # and not the norm a transposed whitener would give (|L e|^2, here different)
    low = whitener_matrix(SIGMA)
    transposed = np.sum((raw @ low.T) ** 2, axis=-1)
    assert not np.allclose(transposed, _by_hand(raw), rtol=1e-3)


def test_yaw_error_of_a_segment_turning_through_pi_is_wrapped():
    """Spinning at 3.2 rad/s, each 1 s segment turns past pi: the exact model's error is ~0."""
    n, dt, omega = 81, 0.125, 3.2
    t = np.arange(n) * dt
    v_l, v_r = np.full(n, -omega / 2), np.full(n, omega / 2)  # track width 1 m
    pose = integrate(np.zeros(n - 1), np.zeros(n - 1), np.full(n - 1, omega), np.full(n - 1, dt))
    pose[:, 2] = wrap_angle(pose[:, 2])
    log = WheelLog(t, v_l, v_r, pose, None, np.zeros(n, dtype=int))
    segs = segment_set([log], [training_windows(log, Horizon(1.0, "s"))])
    assert segs.count >= 5
    res = residuals(get_model("idd"), np.zeros((1, 0)), segs, track_width=1.0)
    np.testing.assert_allclose(res, 0.0, atol=1e-9)
    # a model turning 5 % too slowly stops short of pi where the truth is past it (3.04 against
    # 3.2 rad, wrapped -3.08): off by 5 % of each segment's turn, not by ~2 pi
    slow = residuals(get_model("idd"), np.zeros((1, 0)), segs, track_width=1.0 / 0.95)
    np.testing.assert_allclose(slow[..., 2], -0.05 * omega * 1.0, rtol=1e-6)


@pytest.mark.parametrize(
    ("sigma", "message"),
    [
        (np.eye(2), "3 standard deviations or a symmetric 3x3"),  # symmetric but 2x2
        ([1.0, 2.0], "3 standard deviations or a symmetric 3x3"),
        (np.triu(np.ones((3, 3))), "3 standard deviations or a symmetric 3x3"),  # not symmetric
        (np.diag([1.0, -1.0, 1.0]), "Sigma must be positive definite"),
        ([1.0, 0.0, 1.0], r"standard deviations must be > 0"),
    ],
)
def test_a_sigma_that_is_no_covariance_is_named(sigma, message):
    with pytest.raises(ValueError, match=message):
        whitener_matrix(sigma)
