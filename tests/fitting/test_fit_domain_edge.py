"""The polish reaches an optimum on the edge of where the model is defined.

A stand-in model equal to edd-sym where ``alpha <= 1`` and undefined (NaN
twist) beyond, inside the search bounds; noise-free data with ``alpha = 1``:
least squares' finite differences step over the edge, and must read the
undefined side as a large error, not as none.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from terrain_odom.fitting import FitOptions, Horizon, fit_model, segment_set, training_windows
from terrain_odom.kinematics import get_model
from terrain_odom.sim.model_log import constant_model_log

EDD = get_model("edd-sym")


def _undefined_beyond_one(v_l, v_r, alpha, b_hat):
    v_x, v_y, omega = EDD.twist_fn(v_l, v_r, alpha, b_hat)
    beyond = np.broadcast_to(np.asarray(alpha) > 1.0, np.shape(v_x))
    return np.where(beyond, np.nan, v_x), v_y, np.where(beyond, np.nan, omega)


def test_the_polish_reaches_the_truth_on_the_edge_of_the_model():
    model = dataclasses.replace(EDD, twist_fn=_undefined_beyond_one)
    assert EDD.bounds[0][1] > 1.0  # the undefined side is inside the search bounds
    log = constant_model_log("edd-sym", [1.0, 1.8], seconds=20.0, noise=(0.0, 0.0, 0.0))
    segs = segment_set([log], [training_windows(log, Horizon(2.0, "m"))])
    searched = fit_model(model, segs, options=FitOptions(popsize=6, maxiter=5, polish=False))
    assert searched.loss > 1.0  # five generations alone are far off
    polished = fit_model(model, segs, options=FitOptions(popsize=6, maxiter=5))
    np.testing.assert_allclose(polished.params, [1.0, 1.8], atol=1e-6)
    assert polished.loss < 1e-9
