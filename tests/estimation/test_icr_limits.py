"""The ICR EKF keeps its ICR state inside the configured limits, exactly at a limit it crosses.

Mutation testing found that removing the clip of ``x_icr`` or of ``alpha``
changed no test's outcome; these tests push each state beyond its limit,
through a prior and through the updates, and read the limits from the
configuration object the filter was given.
"""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.config import (
    EkfConfig,
    EkfLimits,
    IcrState,
    PoseIcrSigmas,
    PoseSigmas,
)
from terrain_odom.estimation import IcrEkf, IcrPriors
from terrain_odom.sim.model_log import constant_model_log

LIMITS = EkfLimits(
    half_width_min=0.2, half_width_max=2.0, x_icr_max=0.05, alpha_min=0.8, alpha_max=1.1
)


def _config(estimate_alpha: bool = True) -> EkfConfig:
    return EkfConfig(
        estimate_alpha=estimate_alpha,
        initial=IcrState(0.5, -0.5, 0.0, 1.0),
        sigma_p0=PoseIcrSigmas(0.05, 0.05, 0.02, 0.5, 0.5, 0.3, 0.1),
        sigma_q=PoseIcrSigmas(0.01, 0.01, 0.005, 1e-3, 1e-3, 1e-3, 1e-4),
        sigma_r=PoseSigmas(0.02, 0.02, 0.01),
        limits=LIMITS,
    )


@pytest.mark.parametrize(
    ("prior", "expected"),
    [
        # far outside every limit, on either side
        (IcrState(5.0, -0.01, 3.0, 2.0), "high"),
        (IcrState(0.01, -5.0, -3.0, 0.1), "low"),
    ],
)
def test_a_prior_beyond_the_limits_is_clipped_to_exactly_the_limits(prior, expected):
    ekf = IcrEkf(_config(), priors=IcrPriors(start=prior))
    lim = ekf.config.limits
    y_l, y_r, x_icr, alpha = ekf.params
    if expected == "high":
        assert (y_l, y_r) == (lim.half_width_max, -lim.half_width_min)
        assert (x_icr, alpha) == (lim.x_icr_max, lim.alpha_max)
    else:
        assert (y_l, y_r) == (lim.half_width_min, -lim.half_width_max)
        assert (x_icr, alpha) == (-lim.x_icr_max, lim.alpha_min)


def test_a_prior_inside_the_limits_is_kept_as_it_is():
    prior = IcrState(0.7, -0.6, 0.01, 0.9)
    ekf = IcrEkf(_config(), priors=IcrPriors(start=prior))
    np.testing.assert_array_equal(ekf.params, [0.7, -0.6, 0.01, 0.9])


def _drive(true_params: tuple[float, float, float, float], seconds: float = 30.0):
    """Random arcs and spins of a robot with ICRs ``true_params``; noise-free poses every 2nd row."""
    log = constant_model_log("icr-slip", true_params, seconds=seconds, noise=(0.0, 0.0, 0.0))
    return log.t, log.v_l, log.v_r, log.pose


@pytest.mark.parametrize("sign", [1.0, -1.0])
@pytest.mark.parametrize("state", ["x_icr", "alpha"])
def test_updates_that_pull_a_state_beyond_its_limit_stop_exactly_at_it(state, sign):
    """A robot whose true ``x_icr`` (+-0.4 m) or ``alpha`` (1.5, 0.5) lies outside the limits."""
    truth = (0.5, -0.5, sign * 0.4, 1.0) if state == "x_icr" else (0.5, -0.5, 0.0, 1.0 + sign * 0.5)
    t, v_l, v_r, z = _drive(truth)
    ekf = IcrEkf(_config())
    ekf.reset_pose(z[0])
    states, _, updates = ekf.run_rows((t[0], v_l[0], v_r[0]), t[1:], (v_l[1:], v_r[1:]), z[1:])
    lim = ekf.config.limits
    assert updates == int(np.isfinite(z[1:, 0]).sum())
    x_icr, alpha = states[:, 5], states[:, 6]
    # never beyond, and pinned at the limit on the side of the truth by the end
    assert np.all(np.abs(x_icr) <= lim.x_icr_max)
    assert np.all((lim.alpha_min <= alpha) & (alpha <= lim.alpha_max))
    if state == "x_icr":
        assert x_icr[-1] == sign * lim.x_icr_max
    else:
        assert alpha[-1] == (lim.alpha_max if sign > 0 else lim.alpha_min)


def test_updates_row_by_row_clip_as_the_compiled_rows_do():
    """The per-row ``update`` clips as well (the same constraint after every update)."""
    t, v_l, v_r, z = _drive((0.5, -0.5, 0.4, 1.0), seconds=15.0)
    ekf = IcrEkf(_config())
    ekf.reset_pose(z[0])
    lim = ekf.config.limits
    for k in range(1, len(t)):
        ekf.predict(v_l[k - 1], v_r[k - 1], t[k] - t[k - 1])
        if np.isfinite(z[k, 0]):
            ekf.update(z[k])
        assert abs(ekf.params[2]) <= lim.x_icr_max
    assert ekf.params[2] == lim.x_icr_max
