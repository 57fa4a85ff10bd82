"""Tests of the slip-parameter EKF: features, ICR functions, Jacobian, updates, recovery."""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
import pytest

from bench.slip_ekf import einsum_pose_change_with_jacobian
from terrain_odom.config import (
    Config,
    IcrLimits,
    RobotConfig,
    SlipEkfConfig,
    SlipParams,
    SlipSigmas,
    load_config,
)
from terrain_odom.errors import ConfigError
from terrain_odom.estimation.odometry import run_slip_ekf
from terrain_odom.estimation.slip_ekf import SlipEkf
from terrain_odom.evaluation import settling_time
from terrain_odom.kinematics import integrate, twist_icr, twist_idd, wrap_angle
from terrain_odom.kinematics.slip import SlipModel
from terrain_odom.records import WheelLog
from terrain_odom.sim.slip_scenario import (
    TRACK_WIDTH,
    feature_slip_scenario,
    icr_switch_scenario,
)
from terrain_odom.sim.slip_tuning import SEC41_SLIP_EKF, sec41_config

MODEL = SlipModel(TRACK_WIDTH, 1e-3, True, True, IcrLimits())


@pytest.mark.parametrize(
    ("v_l", "v_r", "a", "k"),
    [
        (1.0, 1.0, 0.0, 0.0),  # straight: no feature
        (-1.0, 1.0, 0.0, 1.0),  # counter-rotation: v = 0, k = 1 (up to eps)
        (1.0, 3.0, 2.0 * 2.0 / TRACK_WIDTH, 2.0 / 4.0),  # v = 2, omega_0 = 2 / B
        (0.0, 0.0, 0.0, 0.0),  # standstill: eps keeps k finite
    ],
)
def test_features_on_hand_cases(v_l, v_r, a, k):
    got_a, got_k = MODEL.features(v_l, v_r)
    assert got_a == pytest.approx(a, abs=1e-12)
    assert got_k == pytest.approx(k, abs=1e-3)


def test_curvature_feature_is_bounded_and_lateral_acceleration_matches_an_arc():
    rng = np.random.default_rng(0)
    v_l, v_r = rng.uniform(-3, 3, (2, 1000))
    a, k = MODEL.features(v_l, v_r)
    assert np.all((k >= 0) & (k <= 1)) and np.all(a >= 0)
    # An arc of radius R at speed v has lateral acceleration v^2 / R.
    v, radius = 1.5, 4.0
    omega = v / radius
    a, _ = MODEL.features(v - omega * TRACK_WIDTH / 2, v + omega * TRACK_WIDTH / 2)
    assert a == pytest.approx(v**2 / radius)


def test_zero_parameters_are_the_ideal_differential_drive():
    rng = np.random.default_rng(1)
    v_l, v_r = rng.uniform(-2, 2, (2, 50))
    y_l, y_r, x_icr = MODEL.icrs(np.zeros(6), *MODEL.features(v_l, v_r))
    np.testing.assert_allclose(y_l, TRACK_WIDTH / 2)
    np.testing.assert_allclose(y_r, -TRACK_WIDTH / 2)
    np.testing.assert_allclose(x_icr, 0.0)
    twist = MODEL.twist(v_l, v_r, np.r_[np.zeros(6), 1.0])
    np.testing.assert_allclose(np.stack(twist), np.stack(twist_idd(v_l, v_r, TRACK_WIDTH)))


def test_icr_functions_and_clipping():
    p = np.array([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    y_l, y_r, x_icr = MODEL.icrs(p, 0.5, 0.25)
    assert (y_l, y_r, x_icr) == pytest.approx((1.23 + 0.5 + 0.5, -(1.23 + 1.5 + 1.0), 2.5 + 1.5))
    y_l, y_r, _ = MODEL.icrs(np.array([-100.0, 0, -100.0, 0, 0, 0]), 1.0, 0.0)
    assert y_l == IcrLimits().half_width_min and y_r == -IcrLimits().half_width_min


@pytest.mark.parametrize("params", [[0.3, 0.5, -0.2, 0.4, 0.1, -0.3, 0.95], [0.0] * 6])
def test_pose_change_jacobian_matches_finite_differences(params):
    rng = np.random.default_rng(2)
    v_l, v_r = rng.uniform(-1, 2, (2, 15))
    v_l[:3] = v_r[:3] = 1.0  # straight samples (series branch of the arcs)
    dt = rng.uniform(0.05, 0.15, 15)
    p = np.array(params)
    change, jac = MODEL.pose_change_with_jacobian(p, v_l, v_r, dt)
    np.testing.assert_allclose(change, MODEL.pose_change(p, v_l, v_r, dt), atol=1e-12)
    numeric = np.empty_like(jac)
    for i in range(p.size):
        d = np.zeros(p.size)
        d[i] = 1e-6
        diff = MODEL.pose_change(p + d, v_l, v_r, dt) - MODEL.pose_change(p - d, v_l, v_r, dt)
        diff[2] = wrap_angle(diff[2])
        numeric[:, i] = diff / 2e-6
    np.testing.assert_allclose(jac, numeric, rtol=1e-6, atol=1e-8)


@pytest.mark.parametrize("n", [6, 7])
@pytest.mark.parametrize("samples", [1, 12, 400])
def test_pose_change_jacobian_equals_the_einsum_chain(n, samples):
    rng = np.random.default_rng(samples)
    v_l, v_r = rng.uniform(-1, 2, (2, samples))
    dt = rng.uniform(0.02, 0.1, samples)
    p = np.array([0.3, 0.5, -0.2, 0.4, 0.1, -0.3, 0.95])[:n]
    _, jac = MODEL.pose_change_with_jacobian(p, v_l, v_r, dt)
    _, reference = einsum_pose_change_with_jacobian(MODEL, p, v_l, v_r, dt)  # bench baseline
    assert jac.shape == (3, n)
    np.testing.assert_allclose(jac, reference, rtol=1e-12, atol=1e-12)


def test_icrs_and_twist_equal_the_clipped_jacobian_values():
    """``icrs``/``twist`` (values only) = the values of ``icrs_with_jacobian``, clipped or not."""
    p = np.array([[10.0, 0.0, -10.0, 0.0, 5.0, 0.0, 1.7], [0.1, 0.2, 0.1, 0.2, 0.0, 0.1, 0.9]])
    a, k = np.array([[0.0, 1.0, 5.0]]).T, np.array([[0.0, 0.5, 1.0]]).T
    values, _ = MODEL.icrs_with_jacobian(p, a, k)
    for got, want in zip(MODEL.icrs(p, a, k), values[:3], strict=True):
        np.testing.assert_array_equal(got, want)
    lim = IcrLimits()
    assert values[0].max() == lim.half_width_max and values[1].max() == -lim.half_width_min
    assert values[3].max() == lim.alpha_max and values[2].max() == lim.x_icr_max
    v_l, v_r = np.array([0.5, 1.0, 2.0]), np.array([1.5, 1.0, -1.0])
    twist = MODEL.twist(v_l, v_r, p[1])
    want = twist_icr(v_l, v_r, *MODEL.icrs_with_jacobian(p[1], *MODEL.features(v_l, v_r))[0])
    for got, ref in zip(twist, want, strict=True):
        np.testing.assert_array_equal(got, ref)


def test_pose_change_is_the_integrated_twist():
    v_l, v_r, dt = np.array([1.0, 0.5, 2.0]), np.array([1.5, 1.5, 1.0]), np.full(3, 0.1)
    p = np.array([0.4, 0.2, 0.3, 0.1, 0.2, 0.1, 0.9])
    expected = integrate(*MODEL.twist(v_l, v_r, p), dt)[-1]
    np.testing.assert_allclose(MODEL.pose_change(p, v_l, v_r, dt), expected)


def _turn_update(ekf: SlipEkf, z: np.ndarray) -> None:
    ekf.update(z, np.full(10, 2.0), np.full(10, 1.0), np.full(10, 0.1))


def test_heading_only_update_moves_the_icr_parameters_but_not_alpha():
    ekf = SlipEkf(SlipEkfConfig(), TRACK_WIDTH)
    full = ekf.model.pose_change(ekf.x, np.full(10, 2.0), np.full(10, 1.0), np.full(10, 0.1))
    _turn_update(ekf, np.array([np.nan, np.nan, full[2] + 0.1]))  # turned less than predicted
    assert ekf.x[6] == 1.0 and ekf.std[6] == pytest.approx(0.1)
    assert np.any(np.abs(ekf.x[:6]) > 1e-3)
    y_l, y_r, _ = ekf.icrs(2.0, 1.0)
    assert y_l - y_r > TRACK_WIDTH  # less turning: wider ICR spacing
    before = ekf.x
    _turn_update(ekf, np.full(3, np.nan))  # nothing measured: nothing changes
    np.testing.assert_array_equal(ekf.x, before)


def test_robust_update_limits_outliers_and_leaves_ordinary_changes_alone():
    v_l, v_r, dt = np.full(10, 2.0), np.full(10, 1.0), np.full(10, 0.1)
    truth = np.array([1.0, 0.5, 1.2, 0.3, 0.4, 0.2])
    z = MODEL.pose_change(truth, v_l, v_r, dt)
    start = SlipEkfConfig(
        estimate_alpha=False, initial=SlipParams(*truth), sigma_p0=SlipSigmas(*(0.1,) * 7)
    )
    for change, same in ((z + [0.05, -0.05, 0.02], True), (z + [1.0, -1.0, 0.5], False)):
        plain, robust = (SlipEkf(dataclasses.replace(start, robust=r), TRACK_WIDTH) for r in (0, 1))
        nis = plain.update(change, v_l, v_r, dt)
        robust.update(change, v_l, v_r, dt)
        assert (nis > 11.345) is not same  # 99 % chi-square bound with 3 degrees of freedom
        if same:
            np.testing.assert_array_equal(robust.x, plain.x)
        else:  # inflated noise: a smaller step and less shrinking of P
            step = [np.linalg.norm(f.x - truth) for f in (robust, plain)]
            assert step[0] < 0.5 * step[1]
            assert np.trace(robust.P) > np.trace(plain.P)


def test_full_update_is_consistent_and_reduces_uncertainty():
    ekf = SlipEkf(SlipEkfConfig(estimate_alpha=False), TRACK_WIDTH)
    p0 = ekf.P
    truth = np.array([1.0, 0.5, 1.2, 0.3, 0.4, 0.2])
    z = MODEL.pose_change(truth, np.full(10, 2.0), np.full(10, 1.0), np.full(10, 0.1))
    nis = ekf.update(z, np.full(10, 2.0), np.full(10, 1.0), np.full(10, 0.1))
    assert np.isfinite(nis) and np.all(np.linalg.eigvalsh(ekf.P) > 0)
    assert np.trace(ekf.P) < np.trace(p0)
    np.testing.assert_allclose(ekf.P, ekf.P.T)


def test_recovers_known_parameters_on_a_simulated_log():
    truth = np.array([1.0, 0.5, 1.2, 0.3, 0.4, 0.2])
    scenario = feature_slip_scenario(truth, duration=120.0, seed=3)
    cfg = Config(
        robot=RobotConfig(track_width=TRACK_WIDTH), slip_ekf=SlipEkfConfig(estimate_alpha=False)
    )
    res = run_slip_ekf(scenario.log, cfg)
    # within 15 % of each parameter (+1 cm): 0.04 on the smallest, 0.2; measured at most 0.065
    np.testing.assert_allclose(res.states[-1, 6:], truth, rtol=0.15, atol=0.01)
    # the ICRs it reports follow the true ones (never seen by the filter) at the end
    late = scenario.log.t > 60.0
    err = np.abs(res.states[late, 3:6] - scenario.icr[late])
    assert np.median(err) < 0.05
    # NEES of the final parameters: a loose consistency check (chi2, 6 dof, 99.9 %: 22.5)
    e = res.states[-1, 6:] - truth
    cov = np.diag(res.stds[-1, 6:] ** 2)
    assert e @ np.linalg.solve(cov, e) < 22.5


def test_update_intervals_follow_the_window(monkeypatch):
    # Straight at 1 m/s, poses every 0.1 s (none at 0.3 s), a second segment from 10 s.
    t = np.r_[np.arange(6) * 0.1, 10.0 + np.arange(6) * 0.1]
    pose = np.c_[t, np.zeros(12), np.zeros(12)]
    pose[3] = np.nan
    log = WheelLog(t, np.ones(12), np.ones(12), pose, None, np.repeat([0, 1], 6))
    spans, changes = [], []
    update = SlipEkf.update

    def spy(self, z, v_l, v_r, dt, **kwargs):
        spans.append(round(float(np.sum(dt)), 9))
        changes.append(float(z[0]))
        return update(self, z, v_l, v_r, dt, **kwargs)

    monkeypatch.setattr(SlipEkf, "update", spy)
    for window, expected in (
        (0.0, [0.1, 0.1, 0.2, 0.1] + [0.1] * 5),  # since the previous pose
        (0.25, [0.1, 0.2, 0.3, 0.3] + [0.1, 0.2, 0.3, 0.3, 0.3]),  # latest >= 0.25 s before
    ):
        spans.clear()
        changes.clear()
        res = run_slip_ekf(log, Config(slip_ekf=SlipEkfConfig(window=window)))
        assert spans == pytest.approx(expected) and res.n_updates == len(expected)
        np.testing.assert_allclose(changes, spans)  # the measured change spans the same rows


def test_negative_window_is_a_config_error(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text("slip_ekf: {window: -0.5}\n")
    with pytest.raises(ConfigError, match="slip_ekf.window"):
        load_config(path)


@functools.cache
def _settling(seed: int, window: float, adapt: bool) -> tuple[float, float]:
    """Settling times (s) of the ICRs after the two Sec. 4.1 changes, |error| <= 0.2 m."""
    scenario = icr_switch_scenario(seed=seed)
    cfg = dataclasses.replace(
        sec41_config(adapt), slip_ekf=dataclasses.replace(SEC41_SLIP_EKF, window=window)
    )
    res = run_slip_ekf(scenario.log, cfg, labels=scenario.log.terrain)
    if adapt:
        assert [c.label for c in res.changes] == ["B", "C"] and all(c.reset for c in res.changes)
    t, icr = scenario.log.t, res.states[:, 3:6]
    out = []
    for t_change in scenario.changes:
        piece = (t >= t_change) & (t < t_change + 10.0)
        final = scenario.icr[piece][-1]
        out.append(settling_time(t[piece], icr[piece], final, [0.2] * 3, t_from=t_change))
    return out[0], out[1]


def test_icrs_settle_within_a_second_of_unsignalled_abrupt_changes():
    # Sec. 4.1 as in the paper: the filter is not told about the changes.
    first, second = np.array([_settling(seed, SEC41_SLIP_EKF.window, False) for seed in range(3)]).T
    assert np.median(first) <= 1.0 and max(first) <= 1.5
    assert max(second) <= 1.0


def test_one_interval_measurement_settles_slowly():
    # The pose change since the previous 10-Hz pose alone: the first updates after the
    # change are too noisy to linearise at, P collapses and the ICRs creep for seconds.
    assert _settling(0, 0.0, False)[0] > 2.0 * _settling(0, SEC41_SLIP_EKF.window, False)[0] + 1.0


def test_terrain_reset_speeds_up_reconvergence_after_an_abrupt_icr_change():
    fast, slow = (
        _settling(1, SEC41_SLIP_EKF.window, True)[1],
        _settling(1, SEC41_SLIP_EKF.window, False)[1],
    )
    assert fast < slow and fast <= 1.0


def test_gps_alone_recovers_the_slip_parameters():
    """Positions without any heading: chord lengths and turns (Sec. 4.2, 1-Hz pose)."""
    truth = np.array([1.0, 0.5, 1.2, 0.3, 0.4, 0.2])
    scenario = feature_slip_scenario(truth, seed=0)
    cfg = Config(robot=RobotConfig(track_width=TRACK_WIDTH))
    cfg = dataclasses.replace(cfg, slip_ekf=dataclasses.replace(cfg.slip_ekf, estimate_alpha=False))
    pose = scenario.log.pose.copy()
    pose[:, 2] = np.nan
    result = run_slip_ekf(dataclasses.replace(scenario.log, pose=pose), cfg)
    assert result.n_updates == int(scenario.log.has_pose.sum()) - 2  # two fixes start the chords
    # within 15 % of each parameter (+1 cm), as with poses; measured at most 0.041
    np.testing.assert_allclose(result.states[-1, 6:12], truth, rtol=0.15, atol=0.01)


def test_heading_only_log_recovers_the_icr_spacing():
    truth = np.array([1.0, 0.5, 1.2, 0.3, 0.4, 0.2])
    scenario = feature_slip_scenario(truth, duration=60.0, seed=5)
    pose = scenario.log.pose.copy()
    pose[:, :2] = np.nan
    log = dataclasses.replace(scenario.log, pose=pose)
    cfg = Config(robot=RobotConfig(track_width=TRACK_WIDTH))
    res = run_slip_ekf(log, cfg)
    assert res.n_updates == np.count_nonzero(log.has_yaw) - 1
    assert res.states[-1, -1] == 1.0  # alpha untouched by heading-only updates
    late = scenario.log.t > 30.0
    width = res.states[late, 3] - res.states[late, 4]
    true_width = scenario.icr[late, 0] - scenario.icr[late, 1]
    assert np.median(np.abs(width - true_width)) < 0.2
