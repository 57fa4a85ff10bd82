"""Tests of the spatial-window model error and the ATE (terrain_odom.evaluation)."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest
from evo.core import metrics as evo_metrics
from evo.core.trajectory import PoseTrajectory3D

from terrain_odom.evaluation import (
    TwistFn,
    Windows,
    absolute_trajectory_error,
    icr_twist_from_rows,
    model_twist,
    spatial_windows,
    summarize,
    window_errors,
)
from terrain_odom.evaluation import metrics as metrics_module
from terrain_odom.kinematics import get_model, integrate, twist_icr
from terrain_odom.records import WheelLog

GRASS_LOG = "warthog_wheels_grass.csv"  # in ../shared/data/drive
WARTHOG_RADIUS = 0.30  # m
WARTHOG_TRACK = 1.08  # m, nominal
TRUE_ICR = {"y_l": 0.9, "y_r": -0.9, "x_icr": 0.1}

IDD = model_twist(get_model("idd"), [], WARTHOG_TRACK)
TRUE_ICR_TWIST = model_twist(get_model("icr"), [TRUE_ICR[k] for k in ("y_l", "y_r", "x_icr")])


def _straight_log(n: int, speed: float = 1.0, segment: np.ndarray | None = None) -> WheelLog:
    """Straight drive along x at ``speed`` m/s, 1 s rows, pose on every row."""
    t = np.arange(n, dtype=float)
    pose = np.c_[speed * t, np.zeros(n), np.zeros(n)]
    seg = np.zeros(n, dtype=int) if segment is None else segment
    return WheelLog(t, np.full(n, speed), np.full(n, speed), pose, None, seg)


def _icr_log(
    n: int = 1200,
    segments: int = 1,
    pose_every: int = 2,
    noise: float = 0.0,
    seed: int = 0,
) -> WheelLog:
    """Log of a robot that exactly follows the true ICR model.

    Wheel speeds are piecewise constant (random in -0.5 .. 1.5 m/s, changed
    every 10 rows), ``dt`` jitters around 0.05 s, each segment starts at a
    random pose, and the pose is measured every ``pose_every`` rows
    (optionally with Gaussian noise of ``noise`` m / rad).
    """
    rng = np.random.default_rng(seed)
    levels = rng.uniform(-0.5, 1.5, size=(n // 10 + 1, 2))
    v_l, v_r = np.repeat(levels, 10, axis=0)[:n].T
    segment = np.repeat(np.arange(segments), -(-n // segments))[:n]
    t = np.cumsum(rng.uniform(0.04, 0.06, n))
    pose = np.full((n, 3), np.nan)
    for s in range(segments):
        rows = np.flatnonzero(segment == s)
        v_x, v_y, omega = twist_icr(v_l[rows], v_r[rows], **TRUE_ICR)
        start = [*rng.uniform(-20.0, 20.0, 2), rng.uniform(-np.pi, np.pi)]
        pose[rows] = integrate(v_x[:-1], v_y[:-1], omega[:-1], np.diff(t[rows]), start=start)
    pose += noise * rng.standard_normal(pose.shape)
    pose[np.arange(n) % pose_every != 0] = np.nan
    return WheelLog(t, v_l, v_r, pose, None, segment, source="synthetic-icr")


def _read_drive_log(path: Path) -> WheelLog:
    """Parse a DRIVE wheel-log CSV (``t, omega_l, omega_r, x, y, yaw, terrain``)."""
    data = np.genfromtxt(path, delimiter=",", names=True, dtype=None, encoding="utf-8")
    pose = np.c_[data["x"], data["y"], data["yaw"]].astype(float)
    return WheelLog(
        t=data["t"].astype(float),
        v_l=WARTHOG_RADIUS * data["omega_l"].astype(float),
        v_r=WARTHOG_RADIUS * data["omega_r"].astype(float),
        pose=pose,
        terrain=data["terrain"].astype(str),
        segment=np.zeros(len(data), dtype=int),
        source=path.name,
    )


def _evo_trajectory(t: np.ndarray, pose: np.ndarray) -> PoseTrajectory3D:
    """Planar poses ``(M, 3)`` as an evo trajectory (z = 0, yaw about z)."""
    quat_wxyz = np.c_[np.cos(pose[:, 2] / 2), np.zeros((len(t), 2)), np.sin(pose[:, 2] / 2)]
    return PoseTrajectory3D(
        positions_xyz=np.c_[pose[:, :2], np.zeros(len(t))],
        orientations_quat_wxyz=quat_wxyz,
        timestamps=t,
    )


# --- windows -----------------------------------------------------------------


def test_windows_on_hand_made_log() -> None:
    """Starts, ends and lengths on a log with gaps, partial poses and 2 segments."""
    nan = np.nan
    x = [0.0, 0.4, nan, 1.0, 1.5, 2.1, 2.5, 3.2, 10.0, 11.0, 12.0, 13.0]
    yaw = [0.0, 0.0, 0.1, 0.0, nan, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    y = [0.0 if np.isfinite(v) else nan for v in x]
    n = len(x)
    log = WheelLog(
        t=np.arange(n, dtype=float),
        v_l=np.ones(n),
        v_r=np.ones(n),
        pose=np.c_[x, y, yaw],
        terrain=None,
        segment=np.array([0] * 8 + [1] * 4),
    )
    w = spatial_windows(log, horizon=1.0)
    # Row 2 is heading-only and row 4 position-only: neither starts nor ends a
    # window, but row 4's position counts in the path. Rows 6, 7 would need
    # segment 1 to reach 1 m, so they are dropped, as is the last row.
    assert w.start.tolist() == [0, 1, 3, 5, 8, 9, 10]
    assert w.end.tolist() == [3, 5, 5, 7, 9, 10, 11]
    np.testing.assert_allclose(w.length, [1.0, 1.7, 1.1, 1.1, 1.0, 1.0, 1.0], atol=1e-12)


def test_window_end_is_first_row_reaching_horizon() -> None:
    """A path of exactly ``horizon`` ends the window."""
    w = spatial_windows(_straight_log(6, speed=0.5))  # 0.5 m per row, h_e = 2 m
    assert w.start.tolist() == [0, 1]
    assert w.end.tolist() == [4, 5]
    assert w.length.tolist() == [2.0, 2.0]


def test_windows_never_cross_segment_change() -> None:
    """No window spans a change of segment id."""
    # Repeated ids after a change are new segments too.
    segment = np.repeat([3, 5, 3, 7, 7, 1], [5, 9, 3, 7, 1, 11])
    segment = np.concatenate([segment, [2] * 3])
    log = _straight_log(segment.size, speed=0.7, segment=segment)
    w = spatial_windows(log, horizon=2.0)
    assert len(w) > 0
    for s, e in zip(w.start, w.end, strict=True):
        assert np.all(segment[s : e + 1] == segment[s])
    # Runs of 3 rows (1.4 m) give no window; the two runs of 7 are one segment.
    runs_with_windows = {int(segment[s]) for s in w.start}
    assert runs_with_windows == {3, 5, 7, 1}
    # Every measured row whose run continues >= 2 m further starts a window.
    assert len(w) == (5 - 3) + (9 - 3) + (8 - 3) + (11 - 3)


def test_invalid_horizon_is_rejected() -> None:
    """A non-positive horizon is an error."""
    with pytest.raises(ValueError, match="horizon"):
        spatial_windows(_straight_log(5), horizon=0.0)


# --- window errors -------------------------------------------------------------


def test_straight_line_model_ten_percent_too_fast() -> None:
    """A model 10 % too fast on a straight line errs by exactly 0.1 m/m."""
    log = _straight_log(30)
    err = window_errors(log, spatial_windows(log), model_twist(get_model("edd-sym"), [1.1, 1.0]))
    np.testing.assert_allclose(err.translation_per_m, 0.1, rtol=0, atol=1e-12)
    np.testing.assert_allclose(err.rotation_per_m, 0.0, atol=1e-12)
    summary = summarize(err)
    assert summary.translation.median == pytest.approx(0.1, abs=1e-12)
    assert summary.translation.count == len(err.windows) == 28


def test_prediction_starts_from_measured_pose_and_uses_window_rows_only() -> None:
    """Each window starts from its measured pose and reads only its own rows."""
    # Straight drive along a heading of 30 deg from (5, -3): every window must
    # start from its measured pose, heading included, to predict it exactly.
    log = _straight_log(12)
    heading = np.radians(30.0)
    xy = log.pose[:, :1] * [np.cos(heading), np.sin(heading)] + [5.0, -3.0]
    pose = np.c_[xy, np.full(len(log), heading)]
    v_r = log.v_r.copy()
    v_r[-1] = 50.0  # the last row's speed is never integrated (no next row)
    log = WheelLog(log.t, log.v_l, v_r, pose, None, log.segment)
    err = window_errors(log, spatial_windows(log), IDD)
    np.testing.assert_allclose(err.translation, 0.0, atol=1e-12)
    np.testing.assert_allclose(err.predicted, log.pose[err.windows.end], atol=1e-12)


def test_true_icr_model_has_zero_error_and_idd_does_not() -> None:
    """The generating ICR model is exact; the ideal differential drive is not."""
    log = _icr_log(segments=3)
    windows = spatial_windows(log)
    assert len(windows) > 100
    exact = window_errors(log, windows, TRUE_ICR_TWIST)
    assert np.max(exact.translation_per_m) < 1e-9
    assert np.max(exact.rotation_per_m) < 1e-7
    idd = summarize(window_errors(log, windows, IDD))
    assert idd.translation.median > 0.02
    assert idd.rotation.median > 5.0


def test_per_row_icr_parameters_use_only_the_window_start_row() -> None:
    """Per-row parameters are read at the window start row only."""
    log = _icr_log(segments=2)
    windows = spatial_windows(log)
    rng = np.random.default_rng(1)
    n = len(log)
    # Plausible but wrong parameters everywhere, the true ones only at starts.
    y_l, y_r = rng.uniform(1.5, 3.0, n), rng.uniform(-3.0, -1.5, n)
    x_icr, alpha = rng.uniform(-1.0, 1.0, n), rng.uniform(0.5, 1.5, n)
    y_l[windows.start], y_r[windows.start] = TRUE_ICR["y_l"], TRUE_ICR["y_r"]
    x_icr[windows.start], alpha[windows.start] = TRUE_ICR["x_icr"], 1.0
    err = window_errors(log, windows, icr_twist_from_rows(windows, y_l, y_r, x_icr, alpha))
    assert np.max(err.translation_per_m) < 1e-9
    # Shifting the estimates by one row (the estimate after the start) fails.
    late = icr_twist_from_rows(
        windows, np.roll(y_l, 1), np.roll(y_r, 1), np.roll(x_icr, 1), np.roll(alpha, 1)
    )
    assert np.median(window_errors(log, windows, late).translation_per_m) > 0.01


def test_per_window_parameters_match_window_by_window_evaluation(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Vectorised per-window parameters equal one-window-at-a-time results."""
    log = _icr_log(n=900, seed=3)
    windows = spatial_windows(log, horizon=1.0)
    params = np.c_[np.linspace(0.8, 1.2, len(windows)), np.linspace(1.0, 2.5, len(windows))]
    edd = get_model("edd-sym")
    one_by_one = np.array(
        [
            window_errors(
                log,
                Windows(windows.start[[i]], windows.end[[i]], windows.length[[i]]),
                model_twist(edd, params[i]),
            ).predicted[0]
            for i in range(len(windows))
        ]
    )
    together = window_errors(log, windows, model_twist(edd, params)).predicted
    np.testing.assert_allclose(together, one_by_one, atol=1e-12)
    # Chunking (many small chunks here) must not change any result.
    monkeypatch.setattr(metrics_module, "_CHUNK_ELEMENTS", 64)
    chunked = window_errors(log, windows, model_twist(edd, params)).predicted
    np.testing.assert_allclose(chunked, together, atol=1e-12)


def test_model_twist_checks_parameters() -> None:
    """Wrong parameter count or a missing track width is reported early."""
    with pytest.raises(ValueError, match="takes parameters"):
        model_twist(get_model("edd-sym"), [1.0])
    with pytest.raises(ValueError, match="track_width"):
        model_twist(get_model("idd"), [])


def test_summary_to_dict_is_json_and_handles_no_windows() -> None:
    """The summary is strict JSON, also without any window."""
    log = _icr_log(n=400)
    summary = summarize(window_errors(log, spatial_windows(log), IDD))
    d = json.loads(json.dumps(summary.to_dict(), allow_nan=False))
    assert set(d) == {"translation_m_per_m", "rotation_deg_per_m"}
    t = d["translation_m_per_m"]
    assert t["q25"] <= t["median"] <= t["q75"] and t["count"] == summary.rotation.count
    short = _straight_log(2)  # 1 m in total: no 2 m window
    empty = summarize(window_errors(short, spatial_windows(short), IDD))
    assert empty.translation.count == 0
    assert json.loads(json.dumps(empty.to_dict(), allow_nan=False))["rotation_deg_per_m"] == {
        "median": None,
        "q25": None,
        "q75": None,
        "mean": None,
        "count": 0,
    }


def test_seven_thousand_rows_give_an_error_per_window() -> None:
    """Every window of a 7000-row log is scored, with the true model's error tiny."""
    log = _icr_log(n=7000, pose_every=4, seed=5)
    windows = spatial_windows(log)
    assert len(windows) > 1000
    errors = window_errors(log, windows, TRUE_ICR_TWIST)
    assert len(errors.translation) == len(windows)
    assert np.all(np.isfinite(errors.translation))


# --- cross-check with evo's RPE -----------------------------------------------------


def _assert_matches_evo_rpe(log: WheelLog, twist_fn: TwistFn, horizon: float = 2.0) -> int:
    """Compare window errors with evo's RPE on evo's own index pairs.

    ``est`` is the model integrated over the whole log from the first measured
    pose; ``ref`` are the measured poses; both sampled at measurement rows.
    evo's consecutive-pairs mode starts a pair at ``i``, then the next at the
    first index whose path from ``i`` is ``>= delta`` (``filter_pairs_by_path``);
    by default on the *estimate's* path, so ``pairs_from_reference=True`` gives
    our definition (the measured path). Returns the number of pairs compared.
    """
    rows = np.flatnonzero(log.has_pose)
    first = rows[0]
    v_x, v_y, omega = twist_fn(log.v_l[None, first:-1], log.v_r[None, first:-1], np.zeros(1, int))
    est_all = integrate(v_x[0], v_y[0], omega[0], np.diff(log.t[first:]), start=log.pose[first])
    traj_ref = _evo_trajectory(log.t[rows], log.pose[rows])
    traj_est = _evo_trajectory(log.t[rows], est_all[rows - first])

    pairs = evo_metrics.id_pairs_from_delta(traj_ref.poses_se3, horizon, evo_metrics.Unit.meters)
    errors = {}
    for relation in (
        evo_metrics.PoseRelation.translation_part,
        evo_metrics.PoseRelation.rotation_angle_rad,
    ):
        rpe = evo_metrics.RPE(
            relation, delta=horizon, delta_unit=evo_metrics.Unit.meters, pairs_from_reference=True
        )
        rpe.process_data((traj_ref, traj_est))
        errors[relation] = rpe.error
    assert [j for _, j in pairs] == rpe.delta_ids

    windows = spatial_windows(log, horizon)
    ours = window_errors(log, windows, twist_fn)
    pair_start, pair_end = rows[[i for i, _ in pairs]], rows[[j for _, j in pairs]]
    at = np.searchsorted(windows.start, pair_start)
    np.testing.assert_array_equal(windows.start[at], pair_start)
    np.testing.assert_array_equal(windows.end[at], pair_end)
    np.testing.assert_allclose(
        ours.translation[at], errors[evo_metrics.PoseRelation.translation_part], rtol=0, atol=1e-9
    )
    np.testing.assert_allclose(
        ours.rotation[at], errors[evo_metrics.PoseRelation.rotation_angle_rad], rtol=0, atol=1e-9
    )
    return len(pairs)


def test_translational_error_equals_evo_rpe_on_synthetic_log() -> None:
    """Window errors equal evo's RPE on a noisy synthetic log."""
    log = _icr_log(n=2000, noise=0.01, seed=7)
    assert _assert_matches_evo_rpe(log, IDD) > 10


def test_translational_error_equals_evo_rpe_on_real_grass_log(drive_dir: Path) -> None:
    """Window errors equal evo's RPE on the real DRIVE grass log."""
    log = _read_drive_log(drive_dir / GRASS_LOG)
    assert _assert_matches_evo_rpe(log, IDD) > 20


# --- ATE ---------------------------------------------------------------------


def _rotate(xy: np.ndarray, angle: float, shift: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return xy @ np.array([[c, -s], [s, c]]).T + shift


def test_ate_recovers_known_rigid_transform() -> None:
    """A rigidly moved trajectory aligns back exactly."""
    log = _icr_log(n=600, seed=2)
    ref = log.pose[:, :2]  # NaN on unmeasured rows: skipped
    est = _rotate(ref, -2.5, np.array([4.0, -7.0]))  # ref = T^-1(est)
    est[np.isnan(est)] = 0.0  # the estimate exists on every row
    result = absolute_trajectory_error(est, ref)
    assert result.rmse < 1e-9
    assert result.count == int(log.has_position.sum())
    measured = log.has_position
    np.testing.assert_allclose(result.alignment.apply(est[measured]), ref[measured], atol=1e-9)
    assert result.alignment.angle == pytest.approx(2.5, abs=1e-12)
    assert json.loads(json.dumps(result.to_dict()))["count"] == result.count


def test_ate_equals_evo_ape_with_alignment() -> None:
    """The ATE equals evo's APE RMSE after ``align``."""
    rng = np.random.default_rng(4)
    log = _icr_log(n=800, seed=4)
    rows = np.flatnonzero(log.has_pose)
    ref_pose = log.pose[rows]
    est_pose = ref_pose.copy()
    est_pose[:, :2] = _rotate(ref_pose[:, :2], 0.7, np.array([1.0, 2.0]))
    est_pose[:, :2] += 0.05 * rng.standard_normal((rows.size, 2)).cumsum(axis=0)
    est_pose[:, 2] += 0.7

    traj_ref = _evo_trajectory(log.t[rows], ref_pose)
    traj_est = _evo_trajectory(log.t[rows], est_pose)
    traj_est.align(traj_ref)
    ape = evo_metrics.APE(evo_metrics.PoseRelation.translation_part)
    ape.process_data((traj_ref, traj_est))
    evo_rmse = ape.get_statistic(evo_metrics.StatisticsType.rmse)

    ours = absolute_trajectory_error(est_pose[:, :2], ref_pose[:, :2])
    assert ours.rmse > 0.01
    assert ours.rmse == pytest.approx(evo_rmse, rel=0, abs=1e-9)


def test_ate_rejects_mismatched_input() -> None:
    """Mismatched shapes and fewer than 2 common rows are errors."""
    with pytest.raises(ValueError, match="shapes differ"):
        absolute_trajectory_error(np.zeros((3, 2)), np.zeros((4, 2)))
    with pytest.raises(ValueError, match="M >= 2"):
        one_common_row = np.array([[0.0, 0.0], [np.nan, 0.0], [np.nan, 1.0]])
        absolute_trajectory_error(np.zeros((3, 2)), one_common_row)


# --- real data sanity -------------------------------------------------------------


def test_real_grass_log_figures(drive_dir: Path) -> None:
    """Error levels of idd and edd-sym on the real grass log (printed)."""
    log = _read_drive_log(drive_dir / GRASS_LOG)
    windows = spatial_windows(log)
    t0 = time.perf_counter()
    idd = summarize(window_errors(log, windows, IDD))
    elapsed = time.perf_counter() - t0
    edd = summarize(window_errors(log, windows, model_twist(get_model("edd-sym"), [0.95, 1.8])))
    print(
        f"\n{GRASS_LOG}: {len(windows)} windows, idd evaluated in {elapsed:.3f} s\n"
        f"  idd B=1.08      : {json.dumps(idd.to_dict())}\n"
        f"  edd-sym .95/1.8 : {json.dumps(edd.to_dict())}"
    )
    assert len(windows) > 1000
    assert elapsed < 1.0
    assert 0.05 < idd.translation.median < 0.3
    assert 1.0 < idd.rotation.median < 10.0
    assert edd.rotation.median < 0.5 * idd.rotation.median
    assert edd.rotation.mean < 0.5 * idd.rotation.mean
    assert edd.translation.median < idd.translation.median
