"""What ``IcrEkf`` reports besides its state: names, ``last_nis``, the log of a reset, errors.

Written for mutants of ``estimation/icr_ekf.py`` no test killed
(docs/testing.md): ``last_nis`` overwritten by an update that measured
nothing (or never set), the terrain change's log line emptied, and the
non-finite error raised without its message.
"""

from __future__ import annotations

import dataclasses
import logging
import math

import numpy as np
import pytest

from terrain_odom.config import EkfConfig, IcrState, TerrainConfig
from terrain_odom.errors import EstimationError
from terrain_odom.estimation import IcrEkf
from terrain_odom.estimation.icr_ekf import HeadingBias, IcrPriors, state_names


def test_last_nis_is_the_last_update_that_measured_something():
    ekf = IcrEkf(EkfConfig(), TerrainConfig())
    assert math.isnan(ekf.last_nis)  # nothing fused yet
    nis = ekf.update([0.1, 0.0, 0.0])
    assert nis > 0.0 and ekf.last_nis == nis
    assert math.isnan(ekf.update([np.nan, np.nan, np.nan]))  # nothing measured ...
    assert ekf.last_nis == nis  # ... leaves the last value
    second = ekf.update([0.1, 0.05, np.nan])
    assert second != nis and ekf.last_nis == second


def test_a_terrain_change_is_logged_with_what_was_done(caplog):
    ekf = IcrEkf(EkfConfig(), TerrainConfig())
    ekf.set_terrain("grass")
    ekf.predict(0.5, 0.5, 1.25)
    with caplog.at_level(logging.INFO, logger="terrain_odom.estimation.icr_ekf"):
        ekf.reset_on_terrain_change("sand")
    assert [r.getMessage() for r in caplog.records] == [
        "terrain grass -> sand at t=1.25 s (restored=False, prior=False)"
    ]


def test_a_non_finite_prior_raises_the_non_finite_error():
    priors = IcrPriors(terrains={"sand": IcrState(math.nan, -0.3, 0.0, 1.0)})
    ekf = IcrEkf(EkfConfig(), TerrainConfig(), priors=priors)
    ekf.set_terrain("grass")
    with pytest.raises(EstimationError, match="^EKF state became non-finite"):
        ekf.reset_on_terrain_change("sand")


@pytest.mark.parametrize(
    ("since", "t", "smallest"),
    [
        (0.0, [0.0, 0.1, 0.2], 0.0),  # the first row at the time of the sample before it
        (0.5, [0.25, 0.6, 0.7], -0.25),  # the first row before it
        (0.0, [0.1, 0.2, 0.2], 0.0),  # a row repeated
    ],
)
def test_run_rows_refuses_time_that_does_not_advance(since, t, smallest):
    ekf = IcrEkf(EkfConfig(), TerrainConfig())
    t = np.array(t)
    speeds = (np.full(3, 0.5), np.full(3, 0.5))
    with pytest.raises(EstimationError, match=f"^predict needs dt > 0 s, got {smallest}"):
        ekf.run_rows((since, 0.5, 0.5), t, speeds, np.full((3, 3), np.nan))
    ekf.run_rows(
        (since, 0.5, 0.5), np.array([since + 0.1]), (t[:1], t[:1]), np.full((1, 3), np.nan)
    )
    assert ekf.t == pytest.approx(0.1)  # one step of 0.1 s advances the filter's clock


def test_state_names_follow_the_estimated_states():
    icr = ("x", "y", "yaw", "y_l", "y_r", "x_icr")
    assert state_names(False) == icr
    assert state_names(True) == (*icr, "alpha")
    assert state_names(False, heading_bias=True) == (*icr, "heading_bias")
    assert state_names(True, heading_bias=True) == (*icr, "alpha", "heading_bias")
    assert (
        len(state_names(False))
        == IcrEkf(dataclasses.replace(EkfConfig(), estimate_alpha=False)).x.size
    )


def test_the_filter_starts_at_the_origin_with_the_configured_icrs():
    cfg = EkfConfig()
    ekf = IcrEkf(cfg)
    assert ekf.pose.tolist() == [0.0, 0.0, 0.0]  # no pose given: the origin
    assert ekf.params.tolist() == [0.25, -0.25, 0.0, 1.0]  # +-B/2 of the default robot
    s = cfg.sigma_p0  # P0 is diagonal, the squares of sigma_p0
    expected = [s.x**2, s.y**2, s.yaw**2, s.y_l**2, s.y_r**2, s.x_icr**2, s.alpha**2]
    np.testing.assert_allclose(ekf.P, np.diag(expected), rtol=1e-15, atol=0.0)
    assert np.isnan(ekf.gating[:2]).all() and not ekf.gating[2:].any()  # nothing rejected yet


@pytest.mark.parametrize("sigma, tau", [(0.0, 10.0), (0.01, 0.0), (0.01, -1.0), (0.01, np.inf)])
def test_a_heading_bias_needs_positive_finite_sigma_and_tau(sigma, tau):
    with pytest.raises(EstimationError, match="^a heading bias needs sigma, tau > 0"):
        IcrEkf(EkfConfig(), heading_bias=HeadingBias(sigma, tau))


@pytest.mark.parametrize("y_r", [0.3, 0.4])
def test_initial_icrs_that_do_not_straddle_are_refused(y_r):
    initial = dataclasses.replace(EkfConfig().initial, y_l=0.3, y_r=y_r)
    with pytest.raises(
        EstimationError, match=f"^initial ICRs need y_l > y_r, got y_l=0.3, y_r={y_r}"
    ):
        IcrEkf(dataclasses.replace(EkfConfig(), initial=initial))


def test_run_rows_reports_the_last_nis():
    ekf = IcrEkf(EkfConfig(), TerrainConfig())
    one = (np.full(1, 0.5), np.full(1, 0.5))
    ekf.run_rows((0.0, 0.5, 0.5), np.array([0.1]), one, np.full((1, 3), np.nan))
    assert math.isnan(ekf.last_nis)  # nothing measured
    ekf.run_rows((0.1, 0.5, 0.5), np.array([0.2]), one, np.array([[0.15, 0.01, np.nan]]))
    nis = ekf.last_nis
    copy = IcrEkf(EkfConfig(), TerrainConfig())
    copy.predict(0.5, 0.5, 0.1)
    copy.predict(0.5, 0.5, 0.1)
    assert nis > 0.0 and nis == pytest.approx(copy.update([0.15, 0.01, np.nan]), rel=1e-12)
    ekf.run_rows((0.2, 0.5, 0.5), np.array([0.3]), one, np.full((1, 3), np.nan))
    assert ekf.last_nis == nis  # a stretch measuring nothing keeps it
