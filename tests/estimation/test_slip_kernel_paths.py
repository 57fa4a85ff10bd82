"""The slip EKF's kernels equal the numpy and filterpy reference on every path.

The kernel tests drive the shipped options (both features on, robust, two
or three iterations, ICRs inside their limits). Mutation testing
(docs/testing.md) asks for the rest: each feature switched off, one
Gauss-Newton iteration, no noise inflation, parameters that put every ICR
and alpha beyond its limit (clipped in the estimate and the dead
reckoning), measurements of one or two components, headings to be
wrapped, chords with and without alpha. And what the reference cannot
check: the random walk of ``predict`` (which it shares), a change measuring
nothing, a covariance that alone overflows, a chord without samples (it
fails instead of being fused as a pose change).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from terrain_odom.config import IcrLimits, SlipEkfConfig, SlipParams
from terrain_odom.errors import EstimationError
from terrain_odom.estimation import _slip_kernels
from terrain_odom.estimation.pose_measurement import chord_turn
from terrain_odom.estimation.slip_ekf import SlipEkf
from terrain_odom.estimation.slip_ekf_reference import FilterpySlipEkf
from terrain_odom.sim.slip_scenario import TRACK_WIDTH

from .conftest import TOLERANCE

NAN = math.nan
LIMITS = IcrLimits(
    half_width_min=0.3, half_width_max=0.9, x_icr_max=0.2, alpha_min=0.9, alpha_max=1.05
)
MODERATE = SlipParams(0.3, 0.5, -0.2, 0.4, 0.1, -0.3, 0.95)
EXTREME = SlipParams(3.0, -4.0, 3.0, 5.0, 2.0, -6.0, 1.3)  # every ICR beyond a limit somewhere
NARROW = SlipParams(-3.0, -4.0, -3.0, -5.0, -2.0, 6.0, 0.7)  # and on the other side
MEASURED = [  # which components of the true pose change are measured (R given or not)
    ((True, True, True), None),
    ((True, False, True), [0.01, 0.02, 0.003]),
    ((False, True, False), None),
    ((False, False, True), [0.01, 0.02, 0.003]),  # heading only: alpha held
    ((True, True, False), None),
]


def _config(alpha: bool, features: tuple[bool, bool], robust: bool, iterations: int, initial):
    return SlipEkfConfig(
        estimate_alpha=alpha,
        lateral_acceleration=features[0],
        curvature=features[1],
        robust=robust,
        iterations=iterations,
        initial=initial,
        limits=LIMITS,
    )


def _samples(count: int, rng: np.random.Generator) -> np.ndarray:
    return np.vstack([rng.uniform(-1.0, 2.0, (2, count)), rng.uniform(0.02, 0.1, count)])


def _assert_same(fast: SlipEkf, slow: SlipEkf, what: str) -> None:
    np.testing.assert_allclose(fast.x, slow.x, rtol=0, atol=TOLERANCE, err_msg=what)
    np.testing.assert_allclose(fast.P, slow.P, rtol=0, atol=TOLERANCE, err_msg=what)


CASES = {
    "lateral acceleration only, one iteration": (True, (True, False), False, 1, MODERATE),
    "curvature only, no alpha": (False, (False, True), True, 3, MODERATE),
    "both, not robust": (True, (True, True), False, 3, MODERATE),
    "beyond every limit": (True, (True, True), True, 2, EXTREME),
    "beyond every limit, no alpha": (False, (True, True), False, 1, EXTREME),
    "beyond the other limits": (True, (True, True), True, 2, NARROW),
}


@pytest.mark.parametrize("case", list(CASES), ids=list(CASES))
def test_every_path_equals_the_reference(case):
    config = _config(*CASES[case])
    fast, slow = SlipEkf(config, TRACK_WIDTH), FilterpySlipEkf(config, TRACK_WIDTH)
    rng = np.random.default_rng(11)
    truth = np.array(dataclasses.astuple(MODERATE))[: len(fast.x)] * 1.4
    model = fast.model
    for k, (measured, r) in enumerate(MEASURED * 2):
        samples = _samples(8, rng)
        for ekf in (fast, slow):
            ekf.predict(0.2)
        v_l, v_r = samples[0, 0], samples[1, 0]
        rows = [ekf.estimate(np.array([1.0, -2.0, 0.5]), v_l, v_r) for ekf in (fast, slow)]
        for got, want in zip(*rows, strict=True):
            np.testing.assert_allclose(got, want, rtol=0, atol=TOLERANCE, err_msg=f"estimate {k}")
        poses = [np.array([1.0, -2.0, 3.0]) for _ in range(2)]
        for ekf, pose in zip((fast, slow), poses, strict=True):
            ekf.dead_reckon(pose, v_l, v_r, 0.3)
        np.testing.assert_allclose(poses[0], poses[1], rtol=0, atol=TOLERANCE)
        z = model.pose_change(truth, *samples) + rng.normal(0.0, 0.01, 3)
        z[2] += 2.0 * math.pi * (k % 3 - 1)  # the same heading change, to be wrapped
        if k == 4 and config.robust:  # positions alone, an outlier: inflated, and not wrapped
            z[:2] += [4.0, -3.5]
        z[~np.array(measured)] = NAN
        nis = [ekf.update(z, *samples, R=r) for ekf in (fast, slow)]
        assert nis[0] == pytest.approx(nis[1], rel=1e-10), k
        _assert_same(fast, slow, f"update {k}")
        first, second = _samples(5, rng), _samples(7, rng)
        arm = np.array([0.3, -0.2])
        c1, c2 = (model.pose_change(truth, *s) for s in (first, second))
        course = chord_turn(c1, np.zeros((3, 1)), c2, np.zeros((3, 1)), arm)[0]
        nis = [ekf.update_course(course, first, second, arm, [1e-4, 1e-4]) for ekf in (fast, slow)]
        assert nis[0] == pytest.approx(nis[1], rel=1e-10), k
        _assert_same(fast, slow, f"course {k}")


def test_predict_is_a_random_walk_of_the_parameters():
    """``P += diag(sigma_q**2) dt`` (the reference shares this step: a known answer instead)."""
    config = SlipEkfConfig()
    ekf = SlipEkf(config, TRACK_WIDTH)
    q = np.array([getattr(config.sigma_q, name) for name in ekf.names]) ** 2
    before = ekf.P
    ekf.predict(0.25)
    np.testing.assert_allclose(ekf.P, before + np.diag(q) * 0.25, rtol=1e-15, atol=0)
    ekf.predict(0.0)
    np.testing.assert_allclose(ekf.P, before + np.diag(q) * 0.25, rtol=1e-15, atol=0)


def test_a_change_measuring_nothing_changes_nothing():
    """The kernel returns NaN and 'finite' for an all-NaN change, ``x`` and ``P`` untouched."""
    ekf = SlipEkf(SlipEkfConfig(), TRACK_WIDTH)
    x, p = ekf.x, ekf.P
    samples = _samples(4, np.random.default_rng(0))
    nis, finite = _slip_kernels.slip_update(
        x, p, np.full(3, NAN), np.ones(3), samples, -1, ekf._model, np.zeros(2), 3, True
    )
    assert math.isnan(nis) and finite is True
    np.testing.assert_array_equal(x, ekf.x)
    np.testing.assert_array_equal(p, ekf.P)


def test_an_update_whose_covariance_alone_overflows_is_not_finite():
    """``finite`` is False where ``P`` overflows though ``x`` stays finite.

    Without the lateral acceleration, ``l1`` and ``l3`` are unobserved (zero
    Jacobian columns, zero gain): their huge covariance is kept, and its mean
    with its transpose overflows.
    """
    config = SlipEkfConfig(lateral_acceleration=False)
    ekf = SlipEkf(config, TRACK_WIDTH)
    x, p = ekf.x, np.eye(7)
    p[0, 2] = p[2, 0] = 1e308
    samples = _samples(4, np.random.default_rng(0))
    z = np.array([0.3, 0.01, 0.05])
    with np.errstate(all="ignore"):  # as compiled: inf, no warning
        _, finite = _slip_kernels.slip_update(
            x, p, z, np.full(3, 1e-4), samples, -1, ekf._model, np.zeros(2), 1, False
        )
    assert np.all(np.isfinite(x)) and not np.all(np.isfinite(p))
    assert finite is False


def test_a_chord_without_samples_is_not_fused():
    """A chord of no samples has no direction: the update fails rather than fusing anything."""
    ekf = SlipEkf(SlipEkfConfig(), TRACK_WIDTH)
    empty = (np.empty(0), np.empty(0), np.empty(0))
    second = (np.ones(5), np.full(5, 1.2), np.full(5, 0.1))
    with pytest.raises(EstimationError), np.errstate(all="ignore"):  # as compiled: NaN, no warning
        ekf.update_course([0.5, 0.1], empty, second, [0.3, 0.0], [1e-4, 1e-4])
