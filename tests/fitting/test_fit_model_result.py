"""What ``fit_model`` reports: its bookkeeping, the options it obeys, its polish and its minimum.

Small simulated logs (``constant_model_log``), a few generations each: every
test runs in well under a second.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np
import pytest

from terrain_odom.fitting import (
    FitOptions,
    FitResult,
    Horizon,
    at_bounds,
    fit_model,
    segment_set,
    training_windows,
)
from terrain_odom.fitting.loss import residuals, squared_loss, whitener_matrix
from terrain_odom.kinematics import get_model
from terrain_odom.sim.model_log import constant_model_log

EDD = [0.9, 1.8]  # edd-sym's alpha, b_hat
FEW = FitOptions(popsize=4, maxiter=5, polish=False)


@pytest.fixture(scope="module")
def segs():
    log = constant_model_log("edd-sym", EDD, seconds=20.0)
    return segment_set([log], [training_windows(log, Horizon(2.0, "m"))])


def _counting(name: str):
    """Return the model ``name`` counting the parameter sets its twist sees, per block."""
    model = get_model(name)
    seen = [0]

    def twist_fn(v_l, v_r, *columns):
        seen[0] += np.shape(columns[0])[0] if np.ndim(columns[0]) > 1 else 1
        return model.twist_fn(v_l, v_r, *columns)

    return dataclasses.replace(model, twist_fn=twist_fn), seen


def _loss(name, params, segs, sigma=None, track_width=None):
    res = residuals(
        get_model(name), np.atleast_2d(params), segs,
        whitener=whitener_matrix(sigma), track_width=track_width,
    )  # fmt: skip
    return float(squared_loss(res)[0])


def test_the_result_records_the_segments_the_loss_and_the_wall_time(segs):
    before = time.perf_counter()
    result = fit_model(get_model("edd-sym"), segs, options=FEW)  # a model object, not a name
    wall = time.perf_counter() - before
    assert result.model == "edd-sym"
    assert (result.segments, result.length, result.duration) == (
        segs.count, segs.length, segs.duration,
    )  # fmt: skip
    assert result.segments == 8 and result.duration > 19.0 and result.length > 16.0
    assert 0.0 < result.seconds <= wall
    assert result.loss == pytest.approx(_loss("edd-sym", result.params, segs), rel=1e-12)
    assert result.as_dict() == {"alpha": result.params[0], "b_hat": result.params[1]}


def test_evaluations_count_every_parameter_set_the_loss_saw(segs):
    model, seen = _counting("edd-sym")
    plain = fit_model(model, segs, options=FEW)
    blocks = len(segs.blocks)
    assert seen[0] == plain.evaluations * blocks
    # differential evolution evaluates popsize * k members per generation and the first population
    assert plain.evaluations == FEW.popsize * 2 * (plain.generations + 1)
    seen[0] = 0
    polished = fit_model(model, segs, options=dataclasses.replace(FEW, polish=True))
    assert seen[0] == polished.evaluations * blocks
    assert polished.evaluations > plain.evaluations  # the same search, then the polish
    assert polished.generations == plain.generations


def test_generations_stop_at_maxiter_unless_the_population_converges_within_tol(segs):
    tight = FitOptions(popsize=4, maxiter=12, tol=1e-12, polish=False)
    assert fit_model("edd-sym", segs, options=tight).generations == 12
    loose = dataclasses.replace(tight, tol=0.5)
    assert fit_model("edd-sym", segs, options=loose).generations < 12
    assert (
        fit_model("edd-sym", segs, options=dataclasses.replace(tight, maxiter=3)).generations == 3
    )


def test_the_population_size_is_popsize_times_the_parameters(segs):
    for popsize in (3, 7):
        options = FitOptions(popsize=popsize, maxiter=2, tol=1e-12, polish=False)
        assert fit_model("edd-sym", segs, options=options).evaluations == popsize * 2 * 3


def test_the_polish_ends_at_the_minimum_of_the_whitened_loss():
    """A few generations, then least squares: a minimum of the loss with Sigma, not without."""
    log = constant_model_log("roc", [0.9, 0.8, 0.5], seconds=20.0, seed=4)
    segs = segment_set([log], [training_windows(log, Horizon(2.0, "m"))])
    sigma = [0.05, 0.2, 0.02]
    options = FitOptions(sigma=sigma, popsize=4, maxiter=4, polish=True)
    result = fit_model("roc", segs, options=options, track_width=1.0)
    unpolished = fit_model("roc", segs, options=dataclasses.replace(options, polish=False),
                           track_width=1.0)  # fmt: skip
    assert result.loss < 0.5 * unpolished.loss
    assert result.loss == pytest.approx(_loss("roc", result.params, segs, sigma, 1.0), rel=1e-12)
    for i in range(3):  # no step along a parameter lowers the reported loss
        for step in (-1e-4, 1e-4):
            moved = result.params + step * np.eye(3)[i]
            assert _loss("roc", moved, segs, sigma, 1.0) >= result.loss * (1 - 1e-9)
    # the minimum without Sigma is elsewhere: the whitener is what the polish minimised
    plain = fit_model("roc", segs, options=dataclasses.replace(options, sigma=None),
                      track_width=1.0)  # fmt: skip
    assert not np.allclose(plain.params, result.params, rtol=1e-3)


def test_a_model_without_parameters_reports_its_loss_and_one_evaluation(segs):
    log = constant_model_log("idd", [], seconds=20.0, seed=2, noise=(0.05, 0.05, 0.02))
    idd_segs = segment_set([log], [training_windows(log, Horizon(2.0, "m"))])
    before = time.perf_counter()
    result = fit_model("idd", idd_segs, track_width=1.0, options=FitOptions(sigma=[0.1, 0.1, 0.05]))
    wall = time.perf_counter() - before
    assert result.params.shape == (0,) and result.as_dict() == {}
    assert (result.generations, result.evaluations, result.at_bounds) == (0, 1, ())
    assert result.loss == pytest.approx(
        _loss("idd", np.zeros((1, 0)), idd_segs, [0.1, 0.1, 0.05], 1.0), rel=1e-12
    )
    assert result.loss > 1.0  # noise of about one Sigma per segment
    assert (result.segments, result.length, result.duration) == (
        idd_segs.count, idd_segs.length, idd_segs.duration,
    )  # fmt: skip
    assert 0.0 < result.seconds <= wall


def test_bounds_given_to_at_bounds_must_pair_with_the_parameters():
    roc = get_model("roc")
    assert at_bounds(roc, np.array([1.0, 0.5, 0.5]), [(0, 2), (0, 1), (0, 1)]) == ()
    with pytest.raises(ValueError, match="zip"):  # a bound missing, not silently unchecked
        at_bounds(roc, np.array([1.0, 0.5, 0.5]), [(0, 2), (0, 1)])


def test_as_dict_refuses_parameters_that_do_not_match_the_model():
    result = FitResult("edd-sym", np.array([0.9]), 0.0, 1, 1.0, 1.0, 0.0, 0, 1)
    with pytest.raises(ValueError, match="zip"):  # one value for alpha and b_hat
        result.as_dict()
