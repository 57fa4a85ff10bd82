"""The compiled slip EKF equals its numpy and filterpy formulation (the reference) to 1e-12.

Both run the same logs through the whole streaming path (windowed pose
changes, heading-only and GPS-alone updates, terrain resets, memory),
simulated and real; :class:`FilterpySlipEkf` is :class:`SlipEkf` with the
former numpy arithmetic. The kernels run as Python (a process's first
calls) or compiled.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from terrain_odom.config import (
    Config,
    IcrLimits,
    PoseChangeSigmas,
    RobotConfig,
    SlipEkfConfig,
    SlipParams,
    load_config,
)
from terrain_odom.errors import EstimationError
from terrain_odom.estimation import _kernel_switch, _slip_kernels, odometry, slip_ekf
from terrain_odom.estimation.pose_measurement import chord_turn
from terrain_odom.estimation.slip_ekf import SlipEkf, model_constants
from terrain_odom.estimation.slip_ekf_reference import FilterpySlipEkf
from terrain_odom.io import read_wheel_log
from terrain_odom.kinematics import compose, wrap_angle
from terrain_odom.kinematics.slip import SlipModel
from terrain_odom.sim.slip_scenario import TRACK_WIDTH, feature_slip_scenario, icr_switch_scenario
from terrain_odom.sim.slip_tuning import sec41_config

from .conftest import TOLERANCE, assert_equal_runs, python_kernels

MODEL = SlipModel(TRACK_WIDTH, 1e-3, True, True, IcrLimits())
PARAMS = np.array([0.3, 0.5, -0.2, 0.4, 0.1, -0.3, 0.95])


def _both(log, cfg, monkeypatch, labels=None):
    """Run ``log`` through the kernels and through the reference; return both results."""
    fast = odometry.run_slip_ekf(log, cfg, labels=labels)
    with monkeypatch.context() as patch:
        patch.setattr(slip_ekf, "SlipEkf", FilterpySlipEkf)  # what OnlineOdometry imports
        slow = odometry.run_slip_ekf(log, cfg, labels=labels)
    return fast, slow


@pytest.mark.parametrize("kernels", ["python", "compiled"], indirect=True)
def test_kernels_equal_the_reference_on_the_sec41_run(monkeypatch, kernels):
    """Sec. 4.1 (abrupt ICR changes, 10-Hz poses, 0.6-s window), the terrain resets on."""
    scenario = icr_switch_scenario(seed=0)
    fast, slow = _both(scenario.log, sec41_config(True), monkeypatch, scenario.log.terrain)
    assert [c.label for c in fast.changes] == ["B", "C"]
    assert_equal_runs(fast, slow)


def test_kernels_equal_the_reference_on_a_real_log(drive_dir, warthog_yaml, monkeypatch):
    """Real Warthog log, grass then asphalt (ICP poses, a reset with memory); compiled."""
    _kernel_switch.compile_kernels()
    cfg = load_config(warthog_yaml)
    log = read_wheel_log(drive_dir / "stitched_grass_to_asphalt.csv", wheel_radius=0.30)
    fast, slow = _both(log, cfg, monkeypatch, labels=log.terrain)
    assert len(fast.changes) == 1 and fast.n_updates > 1000
    assert_equal_runs(fast, slow)


@pytest.mark.parametrize("blank", ["yaw", "position"])
def test_gps_alone_and_heading_only_runs_equal_the_reference(monkeypatch, blank):
    """Chords of fixes without a heading; heading changes alone (alpha held), alpha estimated."""
    scenario = feature_slip_scenario(PARAMS[:6], duration=60.0, seed=1)
    pose = scenario.log.pose.copy()
    pose[:, slice(2, 3) if blank == "yaw" else slice(0, 2)] = np.nan
    log = dataclasses.replace(scenario.log, pose=pose)
    cfg = Config(robot=RobotConfig(track_width=TRACK_WIDTH), slip_ekf=SlipEkfConfig(robust=True))
    _kernel_switch.compile_kernels()
    fast, slow = _both(log, cfg, monkeypatch)
    assert_equal_runs(fast, slow)
    if blank == "position":
        assert np.all(fast.states[:, -1] == 1.0)  # alpha never moved


def test_switch_to_compiled_kernels_mid_run_changes_no_bit(monkeypatch):
    """A run whose kernels are compiled after 300 Python calls equals a wholly compiled one."""
    scenario = icr_switch_scenario(seed=1)
    cfg = sec41_config(True)
    _kernel_switch.compile_kernels()
    compiled = odometry.run_slip_ekf(scenario.log, cfg, labels=scenario.log.terrain)
    python_kernels(monkeypatch)
    monkeypatch.setattr(_kernel_switch, "PURE_CALLS", 300)
    switched = odometry.run_slip_ekf(scenario.log, cfg, labels=scenario.log.terrain)
    assert _kernel_switch._compiled and _slip_kernels.slip_update is _slip_kernels._slip_update
    np.testing.assert_array_equal(switched.states, compiled.states)
    np.testing.assert_array_equal(switched.stds, compiled.stds)


def _samples(count: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    samples = np.vstack([rng.uniform(-1, 2, (2, count)), rng.uniform(0.02, 0.1, count)])
    samples[:, : count // 4] = [[1.0], [1.0], [0.05]]  # straight (series branch of the arcs)
    return samples


@pytest.mark.parametrize("kernels", ["python", "compiled"], indirect=True)
@pytest.mark.parametrize("n", [6, 7])
@pytest.mark.parametrize("count", [1, 12, 400])
def test_pose_change_kernel_equals_the_numpy_jacobian_and_finite_differences(kernels, n, count):
    samples = _samples(count, count)
    x, model = PARAMS[:n], model_constants(MODEL)
    change, jac = _kernels_pose_change(x, samples, model)
    want, want_jac = MODEL.pose_change_with_jacobian(x, *samples)
    np.testing.assert_allclose(change, want, rtol=0, atol=TOLERANCE)
    np.testing.assert_allclose(jac, want_jac, rtol=1e-12, atol=TOLERANCE)
    numeric = np.empty_like(jac)
    for i in range(n):
        d = np.zeros(n)
        d[i] = 1e-6
        diff = _kernels_pose_change(x + d, samples, model)[0]
        diff -= _kernels_pose_change(x - d, samples, model)[0]
        diff[2] = wrap_angle(diff[2])
        numeric[:, i] = diff / 2e-6
    np.testing.assert_allclose(jac, numeric, rtol=1e-6, atol=1e-8)


def _kernels_pose_change(x, samples, model):
    """Call the pose-change kernel in the mode the module is in (Python or compiled)."""
    with np.errstate(all="ignore"):
        return _slip_kernels._pose_change(x, *samples, 0, samples.shape[1], model)


@pytest.mark.parametrize("kernels", ["python", "compiled"], indirect=True)
def test_chord_turn_kernel_equals_the_numpy_one(kernels):
    rng = np.random.default_rng(4)
    for _ in range(5):
        first, second = rng.normal(size=3), rng.normal(size=3)
        j_first, j_second = rng.normal(size=(3, 7)), rng.normal(size=(3, 7))
        arm = rng.normal(size=2)
        got = _slip_kernels._chord_turn(first, j_first, second, j_second, arm)
        want = chord_turn(first, j_first, second, j_second, arm)
        for g, w in zip(got, want, strict=True):
            np.testing.assert_allclose(g, w, rtol=1e-13, atol=1e-14)


@pytest.mark.parametrize("kernels", ["python", "compiled"], indirect=True)
@pytest.mark.parametrize("alpha", [True, False])
def test_step_kernels_equal_the_reference_methods(kernels, alpha):
    """Dead reckoning, a row's estimate, random walk, updates with R, robust outliers, x alone."""
    config = SlipEkfConfig(
        estimate_alpha=alpha, robust=True, initial=SlipParams(*PARAMS), iterations=2
    )
    fast, slow = SlipEkf(config, TRACK_WIDTH), FilterpySlipEkf(config, TRACK_WIDTH)
    samples = _samples(12, 7)
    truth = MODEL.pose_change(PARAMS * 1.5, *samples)
    measurements = [  # z, R
        (truth, None),
        (truth + [1.0, -1.0, 0.5], None),  # an outlier: the noise is inflated
        ([np.nan, np.nan, truth[2] + 3.0], [0.01, 0.02, 0.03]),  # heading only, wrapped
        ([truth[0], np.nan, np.nan], None),  # dx alone
        ([np.nan] * 3, None),  # nothing measured
    ]
    rng = np.random.default_rng(8)
    for z, r in measurements * 3:
        pose, v_l, v_r, dt = rng.normal(size=3), *rng.uniform(-1.5, 1.5, 2), 0.05
        for ekf in (fast, slow):
            ekf.predict(dt)
        poses = [pose.copy(), pose.copy()]
        for ekf, p in zip((fast, slow), poses, strict=True):
            ekf.dead_reckon(p, v_l, v_r, dt)
        np.testing.assert_allclose(poses[0], poses[1], rtol=0, atol=1e-14)
        np.testing.assert_allclose(poses[1], compose(pose, MODEL.pose_change(fast.x, v_l, v_r, dt)))
        nis = [ekf.update(z, *samples, R=r) for ekf in (fast, slow)]
        assert nis[0] == pytest.approx(nis[1], rel=1e-12, nan_ok=True)
        rows = fast.estimate(pose, v_l, v_r), slow.estimate(pose, v_l, v_r)
        for got, want in zip(*rows, strict=True):
            np.testing.assert_allclose(got, want, rtol=0, atol=TOLERANCE)
    np.testing.assert_allclose(fast.x, slow.x, rtol=0, atol=TOLERANCE)
    np.testing.assert_allclose(fast.P, slow.P, rtol=0, atol=TOLERANCE)
    assert fast.last_nis == pytest.approx(slow.last_nis, rel=1e-12)


def test_update_course_equals_the_reference():
    fast, slow = (
        cls(SlipEkfConfig(robust=True), TRACK_WIDTH) for cls in (SlipEkf, FilterpySlipEkf)
    )
    first, second = _samples(9, 1), _samples(14, 2)
    true_first = MODEL.pose_change(PARAMS, *first)
    true_second = MODEL.pose_change(PARAMS, *second)
    arm = np.array([0.4, -0.1])
    z, _ = chord_turn(true_first, np.zeros((3, 1)), true_second, np.zeros((3, 1)), arm)
    for _ in range(3):
        nis = [ekf.update_course(z, first, second, arm, [0.01, 0.001]) for ekf in (fast, slow)]
        assert nis[0] == pytest.approx(nis[1], rel=1e-12)
    np.testing.assert_allclose(fast.x, slow.x, rtol=0, atol=TOLERANCE)
    np.testing.assert_allclose(fast.P, slow.P, rtol=0, atol=TOLERANCE)


def test_non_finite_update_raises():
    ekf = SlipEkf(SlipEkfConfig(sigma_r=PoseChangeSigmas(0.0, 0.0, 0.0)), TRACK_WIDTH)
    ekf._P[:] = 0.0  # no uncertainty and no noise: S is singular
    with pytest.raises(EstimationError, match="non-finite"):
        ekf.update([1.0, 1.0, 0.5], *_samples(5, 0))
