"""The compiled ICR EKF equals its filterpy formulation (the reference) to 1e-12.

Both run the same logs through the whole streaming path (terrain changes,
resets, memory, anchoring), simulated and real; :class:`FilterpyIcrEkf` is
:class:`IcrEkf` with the filterpy predict and update.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from terrain_odom.config import Config, EkfConfig, PoseSigmas, load_config
from terrain_odom.errors import EstimationError
from terrain_odom.estimation import (
    IcrEkf,
    _kernel_switch,
    _kernels,
    icr_step_with_jacobian,
    odometry,
    online,
)
from terrain_odom.estimation._kernels import icr_predict
from terrain_odom.estimation.icr_ekf_reference import FilterpyIcrEkf
from terrain_odom.io import read_wheel_log
from terrain_odom.kinematics.mounting import Mounting

from .conftest import TOLERANCE, assert_equal_runs, python_kernels


def _both(log, cfg, monkeypatch, labels=None):
    """Run ``log`` through the kernels and through the reference; return both results."""
    fast = odometry.run_icr_ekf(log, cfg, labels=labels)
    monkeypatch.setattr(online, "IcrEkf", FilterpyIcrEkf)
    slow = odometry.run_icr_ekf(log, cfg, labels=labels)
    return fast, slow


@pytest.mark.parametrize(
    ("alpha", "kernels"),
    [(True, "python"), (True, "compiled"), (False, "compiled")],
    indirect=["kernels"],
)
def test_kernels_equal_filterpy_on_the_simulated_run(sample_dir, monkeypatch, alpha, kernels):
    cfg = load_config(sample_dir / "config.yaml")
    cfg = dataclasses.replace(cfg, ekf=dataclasses.replace(cfg.ekf, estimate_alpha=alpha))
    log = read_wheel_log(sample_dir / "log.csv", wheel_radius=cfg.robot.wheel_radius)
    fast, slow = _both(log, cfg, monkeypatch, labels=log.terrain)
    assert len(fast.changes) >= 2  # grass -> gravel -> grass: resets and memory exercised
    assert_equal_runs(fast, slow)


def test_kernels_equal_filterpy_on_a_real_log(drive_dir, warthog_yaml, monkeypatch):
    """Real Warthog log, grass then asphalt (ICP poses, a terrain change); compiled kernels."""
    _kernel_switch.compile_kernels()
    cfg = load_config(warthog_yaml)
    log = read_wheel_log(drive_dir / "stitched_grass_to_asphalt.csv", wheel_radius=0.30)
    fast, slow = _both(log, cfg, monkeypatch, labels=log.terrain)
    assert len(fast.changes) == 1
    assert_equal_runs(fast, slow)


def test_switch_to_compiled_kernels_mid_run_changes_no_bit(drive_dir, warthog_yaml, monkeypatch):
    """A run whose kernels are compiled after 300 Python calls equals a wholly compiled one."""
    cfg = load_config(warthog_yaml)
    log = read_wheel_log(drive_dir / "stitched_grass_to_asphalt.csv", wheel_radius=0.30)
    _kernel_switch.compile_kernels()
    compiled = odometry.run_icr_ekf(log, cfg, labels=log.terrain)
    python_kernels(monkeypatch)
    monkeypatch.setattr(_kernel_switch, "PURE_CALLS", 300)
    assert _kernels.icr_predict is _kernels._WRAPPERS["icr_predict"]
    switched = odometry.run_icr_ekf(log, cfg, labels=log.terrain)
    assert _kernel_switch._compiled and _kernels.icr_predict is _kernels._icr_predict  # switched
    np.testing.assert_array_equal(switched.states, compiled.states)
    np.testing.assert_array_equal(switched.stds, compiled.stds)


@pytest.mark.parametrize("mounting", [Mounting(), Mounting(0.5, -0.1, 0.2)])
def test_heading_only_and_custom_noise_updates_equal_filterpy(mounting):
    """Partial rows (yaw only, x-y only, x without y), R per call, yaw wrap, antenna lever arm."""
    cfg = Config().ekf
    fast, slow = IcrEkf(cfg, mounting=mounting), FilterpyIcrEkf(cfg, mounting=mounting)
    rng = np.random.default_rng(3)
    measurements = [
        ([np.nan, np.nan, 3.1], None),
        ([0.3, -0.2, np.nan], [0.01, 0.02, 0.03]),
        ([0.5, 0.1, -3.1], np.diag([0.02, 0.01, 0.005])),
        ([np.nan, 0.4, np.nan], None),  # y without x: nothing measured
        ([0.2, np.nan, -0.4], None),  # x without y: the heading alone
    ]
    for z, r in measurements * 5:
        v_l, v_r = rng.uniform(-1.5, 1.5, 2)
        for ekf in (fast, slow):
            ekf.predict(v_l, v_r, 0.05)
        nis = [ekf.update(z, R=r) for ekf in (fast, slow)]
        assert nis[0] == pytest.approx(nis[1], rel=1e-12, nan_ok=True)
    np.testing.assert_allclose(fast.x, slow.x, rtol=0, atol=TOLERANCE)
    np.testing.assert_allclose(fast.P, slow.P, rtol=0, atol=TOLERANCE)


def test_predict_kernel_matches_the_numpy_step_and_jacobian():
    """One predict: the state is icr_step's and P is F P F^T + Q dt with icr_step's F."""
    x = np.array([1.0, -2.0, 3.1, 0.9, -0.8, 0.1, 0.95])
    rng = np.random.default_rng(0)
    a = rng.normal(size=(7, 7))
    p = a @ a.T
    q = np.arange(1.0, 8.0) * 1e-3
    for v_l, v_r, dt in [(0.4, 1.3, 0.05), (1.0, 1.0, 0.1), (-1.0, 1.0, 0.2)]:
        expected_x, jac = icr_step_with_jacobian(x, v_l, v_r, dt)
        expected_p = jac @ p @ jac.T + np.diag(q * dt)
        got_x, got_p = x.copy(), p.copy()
        icr_predict(got_x, got_p, q, v_l, v_r, dt, np.empty(0))
        np.testing.assert_allclose(got_x, expected_x, rtol=0, atol=1e-14)
        np.testing.assert_allclose(got_p, 0.5 * (expected_p + expected_p.T), rtol=1e-13)


def test_non_finite_update_raises():
    ekf = IcrEkf(dataclasses.replace(EkfConfig(), sigma_r=PoseSigmas(0.0, 0.0, 0.0)))
    ekf.reset_pose([0.0, 0.0, 0.0], sigma=[0.0, 0.0, 0.0])
    with pytest.raises(EstimationError, match="non-finite"):
        ekf.update([1.0, 1.0, 0.5])


def test_kernels_equal_filterpy_with_heading_only_rows_holding_alpha(sample_dir, monkeypatch):
    """Positions blanked on every other pose row: alpha moves on position rows only."""
    cfg = load_config(sample_dir / "config.yaml")
    log = read_wheel_log(sample_dir / "log.csv", wheel_radius=cfg.robot.wheel_radius)
    pose = log.pose.copy()
    rows = np.flatnonzero(log.has_yaw)
    pose[rows[1::2], :2] = np.nan
    log = dataclasses.replace(log, pose=pose)
    fast, slow = _both(log, cfg, monkeypatch)
    assert_equal_runs(fast, slow)
    moved = np.flatnonzero(np.diff(fast.states[:, 6]) != 0.0) + 1
    assert moved.size > 100 and np.all(log.has_position[moved])


def test_a_stretch_of_rows_counts_two_calls_a_row_towards_compiling(monkeypatch):
    """A long stretch compiles first (no 4096 rows in Python); a short run never compiles."""
    python_kernels(monkeypatch)
    monkeypatch.setattr(_kernel_switch, "PURE_CALLS", 100)
    ekf, one_by_one = IcrEkf(EkfConfig()), IcrEkf(EkfConfig())
    t = 0.1 * np.arange(1, 52)
    v_l, v_r = 0.5 + 0.1 * np.sin(t), 0.6 + 0.1 * np.cos(t)
    z = np.full((51, 3), np.nan)
    z[::7] = [[0.1, 0.0, 0.05]]
    states, _, updates = ekf.run_rows((0.0, 0.5, 0.6), t[:40], (v_l[:40], v_r[:40]), z[:40])
    assert _kernel_switch._calls == 80 and not _kernel_switch._compiled and updates == 6
    rest = ekf.run_rows((4.0, v_l[39], v_r[39]), t[40:], (v_l[40:], v_r[40:]), z[40:])[0]
    assert _kernel_switch._compiled  # 80 + 22 > 100: compiled before the stretch ran
    held = (0.5, 0.6)
    for k, row in enumerate(np.vstack([states, rest])):
        one_by_one.predict(*held, t[k] - (t[k - 1] if k else 0.0))
        one_by_one.update(z[k])
        held = (v_l[k], v_r[k])
        np.testing.assert_array_equal(one_by_one.x, row)
