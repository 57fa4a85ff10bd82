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
from terrain_odom.evaluation.ate import absolute_trajectory_error, align_se2
from terrain_odom.evaluation.metrics import window_errors
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


# ------------------------------------------------ gaps found by mutmut (docs/testing.md)
def test_ate_to_dict_names_its_fields_in_their_units():
    result = absolute_trajectory_error(CHIRAL @ np.array([[0.0, -1.0], [1.0, 0.0]]).T + 2.0, CHIRAL)
    d = result.to_dict()
    assert d == {
        "rmse_m": result.rmse,
        "angle_rad": result.alignment.angle,
        "translation_m": result.alignment.translation.tolist(),
        "count": 5,
    }
    assert d["angle_rad"] == pytest.approx(-np.pi / 2, abs=1e-12) and d["rmse_m"] < 1e-12


def test_ate_skips_only_the_rows_not_finite_in_the_estimate_or_the_reference():
    est, ref = CHIRAL + [1.0, 2.0], CHIRAL.copy()
    est[1, 0] = np.nan  # one row without an estimate
    ref[3] = np.nan  # another without a measurement
    result = absolute_trajectory_error(est, ref)
    assert result.count == 3 and result.rmse < 1e-12
    np.testing.assert_allclose(result.alignment.translation, [-1.0, -2.0], atol=1e-12)


def test_align_se2_takes_two_points_and_names_a_wrong_shape():
    two = np.array([[0.0, 0.0], [1.0, 0.0]])
    a = align_se2(two, two @ np.array([[0.0, -1.0], [1.0, 0.0]]).T)
    assert a.angle == pytest.approx(np.pi / 2, abs=1e-12)
    for src, dst in (
        (np.zeros((3, 3)), np.zeros((3, 3))),  # not planar
        (np.zeros((3, 2)), np.zeros((4, 2))),  # not corresponding
        (np.zeros((1, 2)), np.zeros((1, 2))),  # one point
    ):
        with pytest.raises(ValueError, match=r"need two \(M, 2\) position arrays with M >= 2"):
            align_se2(src, dst)


def test_summarize_gives_the_quartiles_of_the_per_metre_errors():
    """101 windows of 1 m with errors 0, 0.01, ..., 1.0 m: quartiles 0.25, 0.5, 0.75 m/m."""
    from terrain_odom.evaluation.metrics import WindowErrors, summarize
    from terrain_odom.evaluation.windows import Windows

    n = 101
    windows = Windows(np.arange(n), np.arange(n) + 1, np.ones(n))
    errors = WindowErrors(windows, np.zeros((n, 3)), np.linspace(0.0, 1.0, n), np.zeros(n))
    stats = summarize(errors).translation
    assert (stats.q25, stats.median, stats.q75, stats.count) == pytest.approx((0.25, 0.5, 0.75, n))
    assert stats.mean == pytest.approx(0.5)


def _two_runs() -> WheelLog:
    """Two segments of 6 rows at 1 s; poses from row 2 of the first, none in the second."""
    n = 12
    pose = np.full((n, 3), np.nan)
    pose[2] = [1.0, 2.0, np.pi / 2]
    pose[4] = [5.0, 5.0, 0.0]  # a later measurement is not re-anchored on
    segment = np.repeat([0, 1], 6)
    return WheelLog(np.arange(n, dtype=float) % 6, np.ones(n), np.ones(n), pose, None, segment)


def test_dead_reckon_starts_at_each_segments_first_pose_and_never_crosses_segments():
    from terrain_odom.evaluation.metrics import dead_reckon

    log = _two_runs()
    n = len(log)
    out = dead_reckon(log, np.ones(n), np.zeros(n), np.zeros(n))  # 1 m/s straight on
    assert np.isnan(out[:2]).all() and np.isnan(out[6:]).all()
    # from (1, 2) heading +y: 1 m per row, the later measurement ignored
    np.testing.assert_allclose(out[2:6], [[1.0, 2.0 + k, np.pi / 2] for k in range(4)], atol=1e-12)
    # a segment without poses before one with: the later one is still reckoned
    swapped = np.r_[6:12, 0:6]
    later = WheelLog(
        log.t[swapped], log.v_l, log.v_r, log.pose[swapped], None, np.repeat([0, 1], 6)
    )
    out = dead_reckon(later, np.ones(n), np.zeros(n), np.zeros(n))
    assert np.isnan(out[:8]).all()
    np.testing.assert_allclose(out[8:], [[1.0, 2.0 + k, np.pi / 2] for k in range(4)], atol=1e-12)


def test_dead_reckon_of_a_segment_with_a_single_pose_starts_there():
    from terrain_odom.evaluation.metrics import dead_reckon

    n = 4
    pose = np.full((n, 3), np.nan)
    pose[0] = [0.0, 0.0, 0.0]
    log = WheelLog(np.arange(n, dtype=float), np.ones(n), np.ones(n), pose, None, np.zeros(n, int))
    out = dead_reckon(log, np.ones(n), np.zeros(n), np.zeros(n))
    np.testing.assert_allclose(out[:, 0], [0.0, 1.0, 2.0, 3.0])


def test_settling_time_boundaries():
    """On the band's edge is inside; a sample at ``t_from`` counts; the time is the next sample's."""
    from terrain_odom.evaluation.metrics import settling_time

    t = np.arange(8.0)
    # outside at 2 and 4, exactly on the band's edge (|1.5 - 1| = 0.5) at 5, inside after
    v = np.array([9.0, 9.0, 9.0, 1.0, 9.0, 1.5, 1.0, 1.0])
    assert settling_time(t, v, [1.0], [0.5], t_from=1.0) == 4.0  # t[4 + 1] - 1
    assert settling_time(t, v, [1.0], [0.5], t_from=4.0) == 1.0  # the sample at t_from counts
    assert settling_time(t, v, [1.0], [0.5], t_from=5.0) == 0.0  # never outside after 5
    assert settling_time(t, np.r_[v[:-1], 3.0], [1.0], [0.5], t_from=0.0) == np.inf
    # two components: the later one decides
    both = np.c_[v, np.r_[1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 9.0, 1.0]]
    assert settling_time(t, both, [1.0, 1.0], [0.5, 0.5], t_from=0.0) == 7.0
