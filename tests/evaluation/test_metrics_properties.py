"""Properties of the metrics with known answers, where mutation testing found holes.

- A window whose heading passes through +-pi: its angular error is the small
  wrapped difference, not ~2 pi (an unwrapped difference survived every test).
- ``align_se2`` on mirrored data: the best orthogonal map is a reflection;
  the returned proper rotation must still be the best *rotation*, which is
  known in closed form in the plane (the guard's removal survived: the old
  test checked the determinant of a matrix rebuilt from the angle, always 1).
"""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.evaluation import spatial_windows
from terrain_odom.evaluation.metrics import absolute_trajectory_error, align_se2, window_errors
from terrain_odom.kinematics import integrate, wrap_angle
from terrain_odom.records import WheelLog

OMEGA = 0.1  # rad/s, the robot's true turn rate
SLOW = 0.5  # the model turns at half the true rate: its yaw lags by up to ~0.1 rad


def _arc_through_pi() -> WheelLog:
    """1 m/s on a left arc from heading pi - 0.5 to pi + 0.5 (wrapped), exact poses at 10 Hz."""
    n, dt = 101, 0.1
    t = np.arange(n) * dt
    v_l, v_r = np.full(n, 1.0 - OMEGA / 2), np.full(n, 1.0 + OMEGA / 2)  # track width 1 m
    pose = integrate(
        np.ones(n - 1),
        np.zeros(n - 1),
        np.full(n - 1, OMEGA),
        np.diff(t),
        start=[0, 0, np.pi - 0.5],
    )
    pose[:, 2] = wrap_angle(pose[:, 2])
    return WheelLog(t, v_l, v_r, pose, None, np.zeros(n, dtype=int))


def _slow_turning(v_l, v_r, window_index):
    return (v_l + v_r) / 2, np.zeros_like(v_l), SLOW * (v_r - v_l)


def test_window_through_pi_reads_the_wrapped_yaw_error():
    log = _arc_through_pi()
    windows = spatial_windows(log, 2.0)
    err = window_errors(log, windows, _slow_turning)
    duration = log.t[windows.end] - log.t[windows.start]
    # windows whose predicted end heading is still short of pi while the measured one is past it
    split = np.sign(err.predicted[:, 2]) != np.sign(log.pose[windows.end, 2])
    assert split.sum() >= 5
    # the model turns (1 - SLOW) * OMEGA rad/s too slowly: the error grows with the duration
    np.testing.assert_allclose(err.rotation, (1 - SLOW) * OMEGA * duration, rtol=1e-9)
    assert np.all(err.rotation < 0.15)
    np.testing.assert_allclose(err.rotation_per_m, np.degrees(err.rotation) / windows.length)


# a chiral point set (no mirror symmetry), and its mirror image moved rigidly
CHIRAL = np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 1.0], [1.0, 3.0], [-1.5, 0.5]])


def _best_rotation_angle(src: np.ndarray, dst: np.ndarray) -> float:
    """Return the least-squares rotation angle in the plane: ``atan2(sum a x b, sum a . b)``, centred."""
    a, b = src - src.mean(axis=0), dst - dst.mean(axis=0)
    return float(np.arctan2(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]), np.sum(a * b)))


def _residual(alignment, src: np.ndarray, dst: np.ndarray) -> float:
    return float(np.sum((alignment.apply(src) - dst) ** 2))


@pytest.mark.parametrize("angle", [0.0, 0.9, -2.6])
def test_alignment_of_mirrored_data_is_the_best_proper_rotation(angle):
    c, s = np.cos(angle), np.sin(angle)
    mirrored = (CHIRAL * [1.0, -1.0]) @ np.array([[c, -s], [s, c]]).T + [3.0, -1.0]
    a = align_se2(CHIRAL, mirrored)
    assert a.angle == pytest.approx(_best_rotation_angle(CHIRAL, mirrored), abs=1e-12)
    # no rotation on a fine grid, with its best translation, does better
    best = np.inf
    for theta in np.linspace(-np.pi, np.pi, 3601):
        rot = np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])
        moved = CHIRAL @ rot.T
        best = min(
            best, float(np.sum((moved - moved.mean(0) - (mirrored - mirrored.mean(0))) ** 2))
        )
    assert _residual(a, CHIRAL, mirrored) <= best + 1e-9
    # and the translation maps the centroids onto each other
    np.testing.assert_allclose(a.apply(CHIRAL).mean(axis=0), mirrored.mean(axis=0), atol=1e-12)


def test_ate_of_a_mirrored_estimate_is_the_best_rotation_residual():
    est = CHIRAL * [1.0, -1.0]
    result = absolute_trajectory_error(est, CHIRAL)
    a = align_se2(est, CHIRAL)
    assert result.rmse == pytest.approx(np.sqrt(_residual(a, est, CHIRAL) / len(est)), rel=1e-12)
    assert result.alignment.angle == pytest.approx(_best_rotation_angle(est, CHIRAL), abs=1e-12)
    assert result.rmse > 0.5  # a mirror image cannot be rotated onto its original
