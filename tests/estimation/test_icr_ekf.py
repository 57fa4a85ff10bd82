"""Tests of the ICR EKF: Jacobians, consistency, convergence, reset, memory, priors."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from terrain_odom.config import (
    EkfConfig,
    EkfLimits,
    IcrSigmas,
    IcrState,
    PoseIcrSigmas,
    PoseSigmas,
    TerrainConfig,
)
from terrain_odom.errors import EstimationError
from terrain_odom.estimation import IcrEkf, IcrPriors, icr_step, icr_step_jacobian
from terrain_odom.kinematics import integrate, twist_icr, wrap_angle


def _fd_jacobian(f, x, eps=1e-6):
    cols = []
    for i in range(x.size):
        dx = np.zeros_like(x)
        dx[i] = eps
        diff = f(x + dx) - f(x - dx)
        diff[2] = wrap_angle(diff[2])
        cols.append(diff / (2 * eps))
    return np.stack(cols, axis=1)


@pytest.mark.parametrize(
    ("state", "v_l", "v_r", "dt"),
    [
        ([1.0, -2.0, 0.7, 0.9, -0.8, 0.1, 0.95], 0.4, 1.3, 0.05),
        ([0.0, 0.0, -2.9, 0.6, -1.1, -0.3, 1.1], -1.0, 1.0, 0.2),  # spin in place
        ([3.0, 1.0, 3.1, 0.7, -0.7, 0.0, 1.0], 1.0, 1.0, 0.1),  # straight: series branch
        ([3.0, 1.0, 0.3, 0.7, -0.9, 0.2], 0.5, 0.6, 0.1),  # no alpha state
    ],
)
def test_step_jacobian_matches_finite_differences(state, v_l, v_r, dt):
    x = np.array(state)
    analytic = icr_step_jacobian(x, v_l, v_r, dt)
    numeric = _fd_jacobian(lambda s: icr_step(s, v_l, v_r, dt), x)
    np.testing.assert_allclose(analytic, numeric, rtol=1e-6, atol=1e-8)


def test_printed_eq9_signs_are_wrong_and_ours_are_right():
    # Chen eq. 9 prints dX/dyaw = -X_dot and dY/dyaw = +Y_dot; correct is -Y_dot and +X_dot.
    x = np.array([0.0, 0.0, 0.5, 0.5, -0.5, 0.0, 1.0])
    jac = icr_step_jacobian(x, 1.0, 1.0, 0.01)  # straight, heading 0.5 rad
    x_dot, y_dot = np.cos(0.5) * 1.0, np.sin(0.5) * 1.0
    assert jac[0, 2] == pytest.approx(-y_dot * 0.01, rel=1e-9)
    assert jac[1, 2] == pytest.approx(x_dot * 0.01, rel=1e-9)
    assert abs(jac[0, 2] - (-x_dot * 0.01)) > 1e-3


def test_step_is_exact_arc_for_constant_twist():
    x = np.array([1.0, 2.0, 0.3, 0.8, -0.6, 0.1, 0.9])
    out = x
    for _ in range(10):
        out = icr_step(out, 0.2, 1.0, 0.1)
    v_x, v_y, w = twist_icr(0.2, 1.0, 0.8, -0.6, 0.1, 0.9)
    ref = integrate([v_x] * 10, [v_y] * 10, [w] * 10, [0.1] * 10, start=x[:3])[-1]
    np.testing.assert_allclose(out[:3], ref, atol=1e-12)
    np.testing.assert_array_equal(out[3:], x[3:])


WIDE = EkfLimits(half_width_min=0.05, half_width_max=20.0, x_icr_max=10.0)
"""Limits far from the ICRs simulated here (on robots of no set track width)."""


def _config(**kw) -> EkfConfig:
    base = dict(
        initial=IcrState(0.5, -0.5, 0.0, 1.0),
        sigma_p0=PoseIcrSigmas(0.05, 0.05, 0.02, 0.5, 0.5, 0.3, 0.1),
        sigma_q=PoseIcrSigmas(0.01, 0.01, 0.005, 1e-4, 1e-4, 1e-4, 1e-5),
        sigma_r=PoseSigmas(0.02, 0.02, 0.01),
        limits=WIDE,
    )
    base.update(kw)
    return EkfConfig(**base)


def _simulate(params, n=3000, dt=0.05, meas_every=2, seed=0, sigma=(0.02, 0.02, 0.01)):
    """Log of a robot with true ICR parameters driving varied arcs; noisy poses."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    v = 1.0 + 0.5 * np.sin(t / 3.0)
    diff = 1.2 * np.sin(t / 2.3) + 0.4 * np.sin(t / 0.9)
    v_l, v_r = v - diff / 2, v + diff / 2
    v_x, v_y, w = twist_icr(v_l, v_r, *params)
    truth = integrate(v_x[:-1], v_y[:-1], w[:-1], np.diff(t))
    z = truth + rng.normal(0.0, sigma, size=truth.shape)
    z[:, 2] = wrap_angle(z[:, 2])
    z[np.arange(n) % meas_every != 0] = np.nan
    return t, v_l, v_r, truth, z


def _run(ekf, t, v_l, v_r, z, on_step=None):
    ekf.reset_pose(z[0])
    for k in range(1, len(t)):
        ekf.predict(v_l[k - 1], v_r[k - 1], t[k] - t[k - 1])
        if np.isfinite(z[k]).any():
            ekf.update(z[k])
        if on_step is not None:
            on_step(k)


def test_converges_to_true_icrs_it_never_saw():
    true = (0.9, -0.75, 0.15, 0.92)
    t, v_l, v_r, _, z = _simulate(true)
    ekf = IcrEkf(_config())
    _run(ekf, t, v_l, v_r, z)
    np.testing.assert_allclose(ekf.params, true, atol=0.02)
    # and its uncertainty is honest: true values within 3 sigma
    assert np.all(np.abs(ekf.params - true) < 3 * ekf.std[3:] + 1e-3)


def test_filter_is_consistent_nees():
    """Average normalised estimation error squared of the pose ~ its dimension."""
    true = (0.8, -0.8, 0.05, 0.95)
    nees = []
    for seed in range(5):
        t, v_l, v_r, truth, z = _simulate(true, n=1500, seed=seed)
        ekf = IcrEkf(_config(initial=IcrState(0.8, -0.8, 0.05, 0.95)))

        def record(k, ekf=ekf, truth=truth):
            if k > 200 and k % 10 == 0:
                err = ekf.x[:3] - truth[k]
                err[2] = wrap_angle(err[2])
                nees.append(err @ np.linalg.solve(ekf.P[:3, :3], err))

        _run(ekf, t, v_l, v_r, z, record)
    # chi2 with 3 dof has mean 3; a well-tuned filter is within a factor ~2 either way
    assert 1.0 < np.mean(nees) < 6.0


def test_covariance_stays_symmetric_positive_definite():
    t, v_l, v_r, _, z = _simulate((0.9, -0.75, 0.15, 0.92), n=800)
    ekf = IcrEkf(_config())

    def check(k):
        P = ekf.P
        assert np.array_equal(P, P.T)
        assert np.linalg.eigvalsh(P).min() > 0.0

    _run(ekf, t, v_l, v_r, z, check)


def test_heading_only_update_changes_yaw_not_position_measurement():
    ekf = IcrEkf(_config())
    ekf.reset_pose([0.0, 0.0, 0.0])
    ekf.predict(1.0, 1.2, 0.1)
    before = ekf.x
    nis = ekf.update([np.nan, np.nan, 0.05])
    assert np.isfinite(nis)
    assert ekf.x[2] != before[2]
    assert np.isnan(ekf.update([np.nan, np.nan, np.nan]))


def _heading_only(z: np.ndarray) -> np.ndarray:
    """Measurements ``z`` with the positions blanked after the first (the anchor)."""
    z = z.copy()
    z[1:, :2] = np.nan
    return z


def test_heading_only_updates_hold_alpha_and_x_icr_and_keep_p_psd():
    """Headings alone: alpha exactly as it was (Schmidt update), P symmetric PSD.

    x_icr does not move either: ``d yaw' / d x_icr = 0`` in the step, so with
    no position ever measured its covariance with the yaw stays zero.
    """
    t, v_l, v_r, _, z = _simulate((0.35, -0.33, 0.05, 1.0), n=800)
    ekf = IcrEkf(_config(initial=IcrState(0.5, -0.5, 0.02, 0.97)))
    seen = []

    def check(k):
        P = ekf.P  # noqa: N806
        assert np.array_equal(P, P.T)
        assert np.linalg.eigvalsh(P).min() > -1e-12 * np.abs(P).max()
        seen.append(ekf.x[5:].copy())

    _run(ekf, t, v_l, v_r, _heading_only(z), check)
    np.testing.assert_array_equal(seen, [[0.02, 0.97]] * len(seen))
    assert ekf.params[0] - ekf.params[1] != 1.0  # the spacing was learned


@pytest.mark.parametrize("seed", [0, 3])
def test_heading_only_run_keeps_the_path_length(seed):
    """Yaw-only poses, true alpha 1, ICRs unlike the initial: the path keeps its length.

    Headings fix the turn rate ``alpha (v_r - v_l) / (y_l - y_r)``, not how
    it splits. With the default process noise, before alpha was held the
    filter raised alpha with the spacing and the path grew by 8-22 % (10
    seeds); held, it is within 1.2 % and the turn rate within 3 %.
    """
    true = (0.28, -0.26, 0.05, 1.0)
    t, v_l, v_r, truth, z = _simulate(true, n=2000, seed=seed)
    sigma_r = PoseSigmas(0.02, 0.02, 0.01)
    ekf = IcrEkf(EkfConfig(initial=IcrState(0.5, -0.5, 0.0, 1.0), sigma_r=sigma_r))
    path = []
    _run(ekf, t, v_l, v_r, _heading_only(z), lambda k: path.append(ekf.pose[:2]))
    true_length = np.hypot(*np.diff(truth[1:, :2], axis=0).T).sum()
    length = np.hypot(*np.diff(np.array(path), axis=0).T).sum()
    assert length == pytest.approx(true_length, rel=0.02)
    assert ekf.params[3] == 1.0
    assert ekf.params[0] - ekf.params[1] == pytest.approx(true[0] - true[1], rel=0.04)


def test_yaw_innovation_is_wrapped():
    ekf = IcrEkf(_config())
    ekf.reset_pose([0.0, 0.0, np.pi - 0.01])
    ekf.update([0.0, 0.0, -np.pi + 0.01])  # 0.02 rad away across the branch cut
    assert abs(wrap_angle(ekf.x[2] - np.pi)) < 0.02


def test_singular_icrs_rejected_and_state_clipped():
    with pytest.raises(EstimationError, match="y_l > y_r"):
        IcrEkf(_config(initial=IcrState(-0.3, 0.3, 0.0, 1.0)))
    ekf = IcrEkf(_config(sigma_p0=PoseIcrSigmas(0.01, 0.01, 0.01, 5.0, 5.0, 0.3, 0.1)))
    ekf.reset_pose([0.0, 0.0, 0.0])
    # a wild yaw measurement after a turn would push y_l below zero without the limits
    for _ in range(5):
        ekf.predict(-1.0, 1.0, 0.1)
        ekf.update([0.0, 0.0, 3.0])
        y_l, y_r = ekf.params[:2]
        assert y_l - y_r >= 2 * ekf.config.limits.half_width_min
        assert np.all(np.isfinite(ekf.x))


def test_bad_dt_is_an_error():
    with pytest.raises(EstimationError, match="dt > 0"):
        IcrEkf(_config()).predict(1.0, 1.0, 0.0)


def test_reset_sets_pb_block_and_clears_correlation():
    cfg = _config(
        sigma_pb=IcrSigmas(0.4, 0.3, 0.2, 0.05),
        sigma_pb_per_terrain={"sand": IcrSigmas(1.0, 1.0, 1.0, 0.2)},
    )
    ekf = IcrEkf(cfg)
    ekf.set_terrain("grass")
    t, v_l, v_r, _, z = _simulate((0.9, -0.75, 0.15, 0.92), n=200)
    _run(ekf, t, v_l, v_r, z)
    params_before, pose_before = ekf.params, ekf.P[:3, :3].copy()
    change = ekf.reset_on_terrain_change("asphalt")
    assert (change.previous, change.label, change.restored) == ("grass", "asphalt", False)
    np.testing.assert_allclose(np.diag(ekf.P)[3:], [0.16, 0.09, 0.04, 0.0025])
    assert np.all(ekf.P[:3, 3:] == 0.0)
    # the pose variances grow by sigma_pb_pose**2 (default 0.02 m, 0.02 m, 0.03 rad)
    np.testing.assert_allclose(ekf.P[:3, :3], pose_before + np.diag([4e-4, 4e-4, 9e-4]))
    np.testing.assert_array_equal(ekf.params, params_before)  # estimate itself kept
    ekf.reset_on_terrain_change("sand")
    np.testing.assert_allclose(np.diag(ekf.P)[3:], [1.0, 1.0, 1.0, 0.04])


def test_terrain_memory_restores_converged_estimate():
    terrain = TerrainConfig(memory=True, memory_min_dwell=5.0)
    ekf = IcrEkf(_config(), terrain)
    ekf.set_terrain("grass")
    t, v_l, v_r, _, z = _simulate((0.9, -0.75, 0.15, 0.92), n=1200)
    _run(ekf, t, v_l, v_r, z)
    grass, grass_cov = ekf.params, ekf.P[3:, 3:]
    ekf.reset_on_terrain_change("asphalt")
    for _ in range(200):  # 20 s on asphalt
        ekf.predict(1.0, 1.0, 0.1)
    ekf.reset_on_terrain_change("asphalt2")  # short stay: asphalt2 not remembered later
    ekf.predict(1.0, 1.0, 0.1)
    change = ekf.reset_on_terrain_change("grass")
    assert change.restored
    np.testing.assert_array_equal(ekf.params, grass)
    # the remembered covariance, not P_B, and no correlation with the pose
    np.testing.assert_array_equal(ekf.P[3:, 3:], grass_cov)
    assert np.all(ekf.P[:3, 3:] == 0.0)
    assert np.all(np.diag(grass_cov) < 0.1 * np.array([1.0, 1.0, 1.0, 0.04]))  # << P_B
    no_memory = IcrEkf(_config(), TerrainConfig(memory=False))
    no_memory.set_terrain("grass")
    no_memory.reset_on_terrain_change("asphalt")
    assert not no_memory.reset_on_terrain_change("grass").restored


def test_reset_speeds_up_reconvergence_after_an_icr_jump():
    """Chen's mechanism: with P_B the filter tracks an abrupt change much faster."""
    before, after = (0.6, -0.6, 0.0, 1.0), (1.2, -1.0, 0.3, 0.85)
    t1, vl1, vr1, _, z1 = _simulate(before, n=1500, seed=1)
    t2, vl2, vr2, _, z2 = _simulate(after, n=1500, seed=2)

    def settle_time(reset: bool) -> float:
        ekf = IcrEkf(_config(sigma_pb=IcrSigmas(0.5, 0.5, 0.3, 0.1)))
        ekf.set_terrain("A")
        _run(ekf, t1, vl1, vr1, z1)
        if reset:
            ekf.reset_on_terrain_change("B")
        ekf.reset_pose(z2[0])
        errs = []
        for k in range(1, len(t2)):
            ekf.predict(vl2[k - 1], vr2[k - 1], t2[k] - t2[k - 1])
            if np.isfinite(z2[k]).any():
                ekf.update(z2[k])
            errs.append(np.max(np.abs(ekf.params[:3] - after[:3])))
        bad = np.flatnonzero(np.array(errs) > 0.1 * 1.0)
        return (bad[-1] + 1) * 0.05 if bad.size else 0.0

    with_reset, without = settle_time(True), settle_time(False)
    assert with_reset < 10.0
    assert without > 5 * with_reset


GRASS, GRAVEL = IcrState(0.42, -0.40, 0.05, 0.93), IcrState(0.60, -0.58, 0.10, 0.85)


def _late_reset_overshoot(pose_sigma: PoseSigmas, seed: int, late: float = 0.2) -> float:
    """Largest ``y_l``/``y_r`` error in the first second after a reset ``late`` s late.

    A slalom (+-0.4 m/s differential, 3-s period, 50-Hz wheels, 10-Hz poses of
    2 cm / 0.01 rad) goes from grass to gravel at 10 s; the filter, settled on
    grass, learns of it ``late`` s after the robot crossed.
    """
    dt, t_change = 0.02, 10.0
    t = np.arange(0.0, 12.0, dt)
    diff = 0.8 * np.sin(2.0 * np.pi * t / 3.0)
    v_l, v_r = 0.5 - diff / 2, 0.5 + diff / 2
    grass, gravel = (np.array(dataclasses.astuple(p)) for p in (GRASS, GRAVEL))
    params = np.where((t < t_change)[:, None], grass, gravel)
    truth = integrate(*(c[:-1] for c in twist_icr(v_l, v_r, *params.T)), np.diff(t))
    z = truth + np.random.default_rng(seed).normal(0.0, (0.02, 0.02, 0.01), truth.shape)
    z[np.arange(t.size) % 5 != 0] = np.nan
    cfg = _config(initial=GRASS, sigma_pb=IcrSigmas(0.5, 0.5, 0.5, 0.1), sigma_pb_pose=pose_sigma)
    ekf = IcrEkf(cfg)
    ekf.set_terrain("grass")
    errors = []

    def step(k: int) -> None:
        if abs(t[k] - (t_change + late)) < dt / 2:
            ekf.reset_on_terrain_change("gravel")
        if t_change + late <= t[k] <= t_change + late + 1.0:
            errors.append(np.max(np.abs(ekf.params[:2] - gravel[:2])))

    _run(ekf, t, v_l, v_r, z, on_step=step)
    return max(errors)


def test_pose_inflation_stops_a_late_reset_from_overshooting():
    """A late reset overshoots less with the pose inflated (sigma_pb_pose).

    In the 0.2 s before the reset the grass model turns the pose estimate a
    few hundredths of a radian wrong, several times its settled deviation;
    without room in the pose the first updates after the reset read that as
    ICR error.
    """
    seeds = range(6)
    without = np.array([_late_reset_overshoot(PoseSigmas(1e-6, 1e-6, 1e-6), s) for s in seeds])
    inflated = np.array([_late_reset_overshoot(EkfConfig().sigma_pb_pose, s) for s in seeds])
    assert np.all(inflated < 0.75 * without)
    assert np.mean(inflated / without) < 0.65


PRIOR_SIGMA = IcrSigmas(0.04, 0.03, 0.02, 0.01)


def _prior_block(ekf: IcrEkf, state: IcrState) -> None:
    """Check the ICR estimate is ``state`` with covariance ``PRIOR_SIGMA**2``, uncorrelated."""
    n = len(ekf.names) - 3
    np.testing.assert_allclose(ekf.params, [state.y_l, state.y_r, state.x_icr, state.alpha][:n])
    sig = np.array([PRIOR_SIGMA.y_l, PRIOR_SIGMA.y_r, PRIOR_SIGMA.x_icr, PRIOR_SIGMA.alpha])
    np.testing.assert_allclose(ekf.P[3:, 3:], np.diag(sig[:n] ** 2))
    assert np.all(ekf.P[:3, 3:] == 0.0)


@pytest.mark.parametrize("estimate_alpha", [True, False])
def test_prior_of_the_first_terrain_seeds_the_filter(estimate_alpha):
    cfg = _config(sigma_prior=PRIOR_SIGMA, estimate_alpha=estimate_alpha)
    ekf = IcrEkf(cfg, priors=IcrPriors(terrains={"grass": GRASS}))
    np.testing.assert_allclose(ekf.params[:3], [0.5, -0.5, 0.0])  # config.initial until named
    ekf.set_terrain("grass")
    _prior_block(ekf, GRASS)  # alpha dropped by the 6-state filter
    t, v_l, v_r, _, z = _simulate((0.9, -0.75, 0.15, 0.92), n=100)
    _run(ekf, t, v_l, v_r, z)
    moved = ekf.params
    ekf.set_terrain("grass")  # renaming (adaptation off) never seeds again
    np.testing.assert_array_equal(ekf.params, moved)


def test_single_prior_is_the_initial_estimate_only():
    ekf = IcrEkf(_config(sigma_prior=PRIOR_SIGMA), priors=IcrPriors(start=GRAVEL))
    _prior_block(ekf, GRAVEL)
    ekf.set_terrain("grass")
    change = ekf.reset_on_terrain_change("gravel")
    assert not change.prior
    np.testing.assert_allclose(np.diag(ekf.P)[3:], [0.25, 0.25, 0.25, 0.01])  # default P_B


def test_change_takes_the_prior_and_a_terrain_without_one_gets_pb():
    cfg = _config(sigma_prior=PRIOR_SIGMA, sigma_pb=IcrSigmas(0.5, 0.5, 0.3, 0.1))
    ekf = IcrEkf(cfg, TerrainConfig(memory=False), priors=IcrPriors(terrains={"gravel": GRAVEL}))
    ekf.set_terrain("grass")  # no prior: config.initial kept
    t, v_l, v_r, _, z = _simulate((0.9, -0.75, 0.15, 0.92), n=200)
    _run(ekf, t, v_l, v_r, z)
    change = ekf.reset_on_terrain_change("gravel")
    assert (change.label, change.restored, change.prior) == ("gravel", False, True)
    _prior_block(ekf, GRAVEL)
    change = ekf.reset_on_terrain_change("sand")
    assert not change.prior
    np.testing.assert_allclose(ekf.params, [0.60, -0.58, 0.10, 0.85])  # estimate kept
    np.testing.assert_allclose(np.diag(ekf.P)[3:], [0.25, 0.25, 0.09, 0.01])


@pytest.mark.parametrize("memory", [True, False])
def test_remembered_estimate_wins_over_the_prior(memory):
    priors = IcrPriors(terrains={"grass": GRASS, "gravel": GRAVEL})
    ekf = IcrEkf(_config(sigma_prior=PRIOR_SIGMA), TerrainConfig(memory=memory), priors=priors)
    ekf.set_terrain("grass")
    t, v_l, v_r, _, z = _simulate((0.9, -0.75, 0.15, 0.92), n=400)  # 20 s, not the prior
    _run(ekf, t, v_l, v_r, z)
    online = ekf.params
    assert ekf.reset_on_terrain_change("gravel").prior
    for _ in range(10):
        ekf.predict(1.0, 1.0, 0.1)
    change = ekf.reset_on_terrain_change("grass")
    assert (change.restored, change.prior) == (memory, not memory)
    if memory:
        np.testing.assert_array_equal(ekf.params, online)
    else:
        _prior_block(ekf, GRASS)
