"""Parameter files as ICR EKF priors (``run --priors``)."""

from __future__ import annotations

import pytest

from terrain_odom.config import IcrState
from terrain_odom.estimation import IcrPriors
from terrain_odom.io.params import ANY_TERRAIN, ModelParams, ParamSet, icr_priors


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


def test_parameters_at_a_bound_survive_a_write_and_read(tmp_path):
    from terrain_odom.io.params import read_params, write_params

    ps = ParamSet({"alpha": 0.93, "beta_1": 0.65, "beta_2": 0.0}, {"loss": 1.0}, ("beta_2",))
    path = tmp_path / "roc.yaml"
    write_params(path, ModelParams("roc", {ANY_TERRAIN: ps}, 1.08))
    assert "at_bounds: [beta_2]" in path.read_text()
    assert read_params(path).sets[ANY_TERRAIN].at_bounds == ("beta_2",)


def test_at_bounds_must_name_parameters_of_the_model(tmp_path):
    from terrain_odom.errors import InputFileError
    from terrain_odom.io.params import read_params

    path = tmp_path / "roc.yaml"
    path.write_text(
        "format_version: 2\nmodel: roc\ntrack_width: 1.08\n"
        "params: {alpha: 0.9, beta_1: 0.6, beta_2: 0.0}\nat_bounds: [gamma]\n"
    )
    with pytest.raises(InputFileError, match="at_bounds must list parameter names"):
        read_params(path)
