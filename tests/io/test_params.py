"""Parameter files: what a write keeps, what a read refuses."""

from __future__ import annotations

import pytest

from terrain_odom.fitting.params import ANY_TERRAIN, ModelParams, ParamSet


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
