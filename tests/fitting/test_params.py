"""Fit results: the ICR EKF's priors from them, and the checks a set must pass."""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.config import IcrState
from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.estimation import IcrPriors
from terrain_odom.fitting.params import (
    ANY_TERRAIN,
    GEOMETRY_RTOL,
    ModelParams,
    ParamSet,
    check_geometry,
    check_sets,
    icr_priors,
)
from terrain_odom.records import WheelLog

ROC_BOUNDS = [(0.0, 1.5), (0.0, 1.0), (0.0, 1.0)]


def _param_file(model: str, sets: dict[str, dict[str, float]]) -> ModelParams:
    return ModelParams(model, {k: ParamSet(v) for k, v in sets.items()})


def test_priors_from_parameter_files():
    slip = {"y_l": 0.42, "y_r": -0.40, "x_icr": 0.05, "alpha": 0.93}
    per_terrain = icr_priors(_param_file("icr-slip", {"grass": slip}))
    assert per_terrain == IcrPriors(terrains={"grass": IcrState(0.42, -0.40, 0.05, 0.93)})
    icr = {"y_l": 0.6, "y_r": -0.58, "x_icr": 0.1}
    single = icr_priors(_param_file("icr", {ANY_TERRAIN: icr}))
    assert single == IcrPriors(start=IcrState(0.6, -0.58, 0.1, 1.0))
    with pytest.raises(ValueError, match="no ICR state; fit 'icr' or 'icr-slip'"):
        icr_priors(_param_file("edd-sym", {ANY_TERRAIN: {"alpha": 1, "b_hat": 1}}))
    with pytest.raises(ValueError, match="terrain 'grass' needs y_l > 0 > y_r"):
        icr_priors(_param_file("icr", {"grass": {**icr, "y_r": 0.2}}))


def _roc(params: dict[str, float], at_bounds: tuple[str, ...] = ()) -> ModelParams:
    return ModelParams("roc", {"grass": ParamSet(params, {}, at_bounds)})


def test_a_set_inside_its_bounds_with_true_at_bounds_passes():
    check_sets(_roc({"alpha": 0.9, "beta_1": 0.6, "beta_2": 0.0}, ("beta_2",)), ROC_BOUNDS, "f")
    check_sets(_roc({"alpha": 9.0, "beta_1": 0.6, "beta_2": 0.0}), None, "f")  # no bounds


@pytest.mark.parametrize(
    ("params", "at_bounds", "message"),
    [
        (
            {"alpha": 1.6, "beta_1": 0.6, "beta_2": 0.5},
            (),
            "f: terrains.grass.params.alpha: 1.6 lies",
        ),
        (
            {"alpha": 0.9, "beta_1": 0.6, "beta_2": 0.0},
            (),
            r"at_bounds: says \[\], but .* \['beta_2'\]",
        ),
        ({"alpha": 0.9, "beta_1": 0.6, "beta_2": 0.5}, ("alpha",), "at_bounds: says"),
    ],
)
def test_a_set_its_file_contradicts_is_refused(params, at_bounds, message):
    with pytest.raises(InputFileError, match=message):
        check_sets(_roc(params, at_bounds), ROC_BOUNDS, "f")


def test_swapped_icrs_are_refused_without_bounds_too():
    icr = ModelParams("icr", {ANY_TERRAIN: ParamSet({"y_l": -0.4, "y_r": 0.4, "x_icr": 0.0})})
    with pytest.raises(InputFileError, match=r"^f: params: the ICRs need y_l > 0 > y_r"):
        check_sets(icr, None, "f")


def test_geometry_differing_beyond_its_tolerance_is_refused():
    params = ModelParams("idd", {ANY_TERRAIN: ParamSet({})}, 0.5, {"wheel_radius": 0.3})
    check_geometry(params, 0.3 * (1 + 0.5 * GEOMETRY_RTOL), 0.5, "p.yaml")
    check_geometry(ModelParams("idd", {ANY_TERRAIN: ParamSet({})}), 9.0, 9.0, "p.yaml")
    with pytest.raises(ConfigError, match=r"p.yaml: fitted with robot.wheel_radius 0.3 m"):
        check_geometry(params, 0.3 * (1 + 2 * GEOMETRY_RTOL), 0.5, "p.yaml")
    with pytest.raises(ConfigError, match="robot.track_width 0.5 m, but .* 0.51 m"):
        check_geometry(params, 0.3, 0.51, "p.yaml")


# ------------------------------------------------ gaps found by mutmut (its survivors)
@pytest.mark.parametrize("side", ["y_l", "y_r"])
def test_an_icr_exactly_on_the_centre_line_is_refused(side):
    icr = {"y_l": 0.4, "y_r": -0.4, "x_icr": 0.0, side: 0.0}
    with pytest.raises(InputFileError, match="the ICRs need y_l > 0 > y_r"):
        check_sets(ModelParams("icr", {ANY_TERRAIN: ParamSet(icr)}), None, "f")
    with pytest.raises(ValueError, match="the parameter set needs y_l > 0 > y_r"):
        icr_priors(ModelParams("icr", {ANY_TERRAIN: ParamSet(icr)}))


def test_every_set_is_checked_without_bounds_too():
    good, swapped = {"y_l": 0.4, "y_r": -0.4, "x_icr": 0.0}, {"y_l": -0.4, "y_r": 0.4, "x_icr": 0.0}
    params = ModelParams("icr", {"grass": ParamSet(good), "gravel": ParamSet(swapped)})
    with pytest.raises(InputFileError, match=r"^f: terrains\.gravel\.params: the ICRs"):
        check_sets(params, None, "f")


def test_a_value_on_the_files_own_bound_is_inside_it_and_flagged_by_it():
    """An alpha of 0.9 on the file's bound 0.9 (far from the model's 1.5): inside, and at a bound."""
    bounds = [(0.0, 0.9), (0.0, 1.0), (0.0, 1.0)]
    on_bound = {"alpha": 0.9, "beta_1": 0.6, "beta_2": 0.5}
    check_sets(_roc(on_bound, ("alpha",)), bounds, "f")
    with pytest.raises(InputFileError, match=r"at_bounds: says \[\], but .* \['alpha'\]"):
        check_sets(_roc(on_bound), bounds, "f")


def test_messages_name_what_to_do():
    per_terrain = ModelParams("icr", {"grass": ParamSet({"y_l": 0.4, "y_r": -0.4, "x_icr": 0.0})})
    log = WheelLog(np.arange(3.0), np.ones(3), np.ones(3), np.zeros((3, 3)), None, np.zeros(3, int))
    with pytest.raises(InputFileError) as raised:
        per_terrain.rows(log)
    assert str(raised.value) == (
        "<memory>: no terrain column, but the icr parameters are per terrain (['grass'])"
    )
    params = ModelParams("idd", {ANY_TERRAIN: ParamSet({})}, 0.5)
    with pytest.raises(ConfigError) as raised:
        check_geometry(params, 0.1, 0.6, "p.yaml")
    assert str(raised.value).endswith("0.6 m: give the configuration it was fitted with (--config)")
