"""Tests of offline model identification (terrain_odom.fitting.identify) on simulated logs."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from terrain_odom.errors import EstimationError
from terrain_odom.evaluation import spatial_windows
from terrain_odom.fitting import (
    FitOptions,
    Horizon,
    at_bounds,
    fit_model,
    parse_horizon,
    residuals,
    segment_set,
    training_windows,
)
from terrain_odom.kinematics import get_model
from terrain_odom.records import WheelLog
from terrain_odom.sim.model_log import constant_model_log

H2 = Horizon(2.0, "m")
FAST = FitOptions(popsize=8, maxiter=200)

TRUTH = {
    "edd-sym": [0.9, 1.8],
    "edd-asym": [0.9, 0.95, 0.1, 0.9, -1.1],
    "roc": [0.9, 0.8, 0.5],
    "linear": [0.45, 0.45, -0.05, 0.05, -0.5, 0.5],
    "icr": [0.9, -1.1, 0.1],
    "icr-slip": [0.9, -1.1, 0.1, 0.9],
}


def _segments(logs, horizon=H2):
    return segment_set(logs, [training_windows(log, horizon) for log in logs])


def _loss(model, params, segs, track_width=1.0):
    res = residuals(get_model(model), np.atleast_2d(params), segs, track_width=track_width)
    return float(np.sum(res**2))


@pytest.mark.parametrize("name", sorted(TRUTH))
def test_each_model_recovered_on_its_own_data(name):
    log = constant_model_log(name, TRUTH[name], seconds=60.0, seed=1)
    result = fit_model(name, _segments([log]), options=FAST, track_width=1.0)
    truth = np.array(TRUTH[name])
    # ROC's curvature law is weakly excited; its beta_1, beta_2 get a looser bound
    tol = np.where(np.abs(truth) > 0.3, 0.03, 0.01) if name != "roc" else [0.01, 0.2, 0.2]
    assert np.all(np.abs(result.params - truth) <= tol), (result.params, truth)
    assert result.loss <= _loss(name, truth, _segments([log])) + 1e-9


@pytest.mark.parametrize("name", ["icr", "icr-slip"])
def test_icr_recovered_within_1_cm(name):
    log = constant_model_log(name, TRUTH[name], seconds=90.0, seed=2)
    result = fit_model(name, _segments([log]), options=FAST, track_width=1.0)
    np.testing.assert_allclose(result.params[:3], TRUTH[name][:3], atol=0.01)


def test_noise_free_fit_is_exact():
    log = constant_model_log("edd-asym", TRUTH["edd-asym"], seconds=30.0, noise=(0.0, 0.0, 0.0))
    result = fit_model("edd-asym", _segments([log]), options=FAST)
    np.testing.assert_allclose(result.params, TRUTH["edd-asym"], atol=1e-5)
    assert result.loss < 1e-12


def test_fit_is_reproducible_and_seeded():
    segs = _segments([constant_model_log("edd-sym", TRUTH["edd-sym"], seconds=30.0)])
    opt = dataclasses.replace(FAST, polish=False)
    a = fit_model("edd-sym", segs, options=opt)
    b = fit_model("edd-sym", segs, options=opt)
    c = fit_model("edd-sym", segs, options=dataclasses.replace(opt, seed=5))
    np.testing.assert_array_equal(a.params, b.params)
    assert not np.array_equal(a.params, c.params)


def test_bounds_are_respected():
    # alpha = 1.7 is outside edd-sym's bound [0, 1.5]: the fit stops on the bound
    log = constant_model_log("edd-sym", [1.7, 1.8], seconds=30.0)
    result = fit_model("edd-sym", _segments([log]), options=FAST)
    (lo_a, hi_a), (lo_b, hi_b) = get_model("edd-sym").bounds
    assert lo_a <= result.params[0] <= hi_a and lo_b <= result.params[1] <= hi_b
    assert result.params[0] == pytest.approx(hi_a)
    assert result.at_bounds == ("alpha",)


def test_fits_inside_the_bounds_are_not_flagged():
    log = constant_model_log("edd-sym", TRUTH["edd-sym"], seconds=30.0)
    assert fit_model("edd-sym", _segments([log]), options=FAST).at_bounds == ()


def test_at_bounds_is_relative_to_the_bound_with_a_least_scale_of_one():
    roc = get_model("roc")  # bounds alpha (0, 1.5), beta_1 (-0.95, 50), beta_2 (0, 50)
    assert at_bounds(roc, np.array([1.49, 0.5, 0.011])) == ("alpha",)
    assert at_bounds(roc, np.array([1.0, -0.945, 0.5])) == ("beta_1",)
    assert at_bounds(roc, np.array([1.0, 49.6, 0.009])) == ("beta_1", "beta_2")
    assert at_bounds(roc, np.array([1.0, 0.5, 0.5])) == ()


def _straight(log: WheelLog) -> WheelLog:
    """Return the log with both tracks at their mean speed (no turning) and its poses then."""
    v = 0.5 * (log.v_l + log.v_r)
    x = np.r_[0.0, np.cumsum(v[:-1] * np.diff(log.t))]
    pose = np.where(np.isfinite(log.pose), np.c_[x, 0 * x, 0 * x], np.nan)
    return dataclasses.replace(log, v_l=v, v_r=v, pose=pose)


def test_data_without_turning_or_motion_is_refused_with_the_reason():
    log = constant_model_log("edd-sym", TRUTH["edd-sym"], seconds=30.0)
    with pytest.raises(EstimationError, match=r"turn 0\.0 deg in all: no turning"):
        fit_model("edd-sym", _segments([_straight(log)]), options=FAST)
    still = dataclasses.replace(log, v_l=0 * log.v_l, v_r=0 * log.v_r)
    with pytest.raises(EstimationError, match="no motion"):
        fit_model("icr", _segments([still], Horizon(2.0, "s")), options=FAST)


def test_loss_is_invariant_to_splitting_a_log_into_files():
    log = constant_model_log("icr-slip", TRUTH["icr-slip"], seconds=60.0, segments=3)
    pieces = [_select_rows(log, log.segment == s) for s in range(3)]
    whole = _segments([log])
    split = _segments(pieces)
    assert whole.count == split.count > 10
    p = [0.8, -1.0, 0.05, 0.95]
    assert _loss("icr-slip", p, split) == pytest.approx(_loss("icr-slip", p, whole), rel=1e-12)
    # cutting a segment-free log at a segment boundary of the chain gives the same segments too
    one = constant_model_log("icr-slip", TRUTH["icr-slip"], seconds=60.0)
    w = training_windows(one, H2)
    cut = int(w.end[5])
    first = _select_rows(one, np.arange(len(one)) <= cut)
    second = _select_rows(one, np.arange(len(one)) >= cut)
    assert _loss("icr-slip", p, _segments([first, second])) == pytest.approx(
        _loss("icr-slip", p, _segments([one])), rel=1e-12
    )


def _select_rows(log: WheelLog, mask: np.ndarray) -> WheelLog:
    return WheelLog(
        log.t[mask], log.v_l[mask], log.v_r[mask], log.pose[mask],
        None if log.terrain is None else log.terrain[mask], log.segment[mask], log.source,
    )  # fmt: skip


def test_segments_never_cross_a_segment_break_and_do_not_overlap():
    log = constant_model_log("edd-sym", TRUTH["edd-sym"], seconds=40.0, segments=4)
    for horizon in (H2, Horizon(1.5, "s")):
        w = training_windows(log, horizon)
        assert len(w) > 8
        assert np.all(log.segment[w.start] == log.segment[w.end])
        assert np.all(w.start[1:] >= w.end[:-1])
        # each segment is one of the evaluation windows (same definition)
        full = horizon.windows(log)
        assert set(zip(w.start, w.end, strict=True)) <= set(zip(full.start, full.end, strict=True))


def test_time_horizon_segments_last_at_least_the_duration():
    log = constant_model_log("edd-sym", TRUTH["edd-sym"], seconds=20.0)
    w = training_windows(log, parse_horizon("2s"))
    duration = log.t[w.end] - log.t[w.start]
    assert np.all(duration >= 2.0 - 1e-9) and np.all(duration < 2.0 + 0.2)
    spatial = spatial_windows(log, 2.0)
    assert np.all(spatial.length >= 2.0)


def test_merging_constant_steps_keeps_the_loss():
    # wheel readings held for several rows are merged into one step: loss unchanged
    log = constant_model_log("roc", TRUTH["roc"], seconds=30.0)
    segs = _segments([log])
    steps = sum(int(np.count_nonzero(b.dt)) for b in segs.blocks)
    assert steps < 0.2 * sum(
        int(w) for w in (training_windows(log, H2).end - training_windows(log, H2).start)
    )
    from terrain_odom.evaluation import model_twist, window_errors

    w = training_windows(log, H2)
    p = [0.85, 0.5, 0.3]
    err = window_errors(log, w, model_twist(get_model("roc"), p, 1.0))
    reference = np.sum(err.translation**2 + err.rotation**2)
    assert _loss("roc", p, segs) == pytest.approx(reference, rel=1e-9)


def test_per_terrain_segments_stay_on_their_terrain():
    a = constant_model_log("edd-sym", [0.9, 1.8], seconds=30.0, terrain="grass")
    b = constant_model_log("edd-sym", [0.8, 2.5], seconds=30.0, terrain="asphalt", seed=3)
    both = _concat(a, b)
    wg = training_windows(both, H2, "grass")
    wa = training_windows(both, H2, "asphalt")
    assert np.all(both.terrain[wg.start] == "grass") and np.all(both.terrain[wg.end] == "grass")
    assert np.all(both.terrain[wa.start] == "asphalt") and np.all(both.terrain[wa.end] == "asphalt")
    fa = fit_model("edd-sym", segment_set([both], [wa]), options=FAST)
    np.testing.assert_allclose(fa.params, [0.8, 2.5], atol=0.03)


def _concat(a: WheelLog, b: WheelLog) -> WheelLog:
    """``b`` appended to ``a`` in one segment, its poses re-anchored at ``a``'s last true pose."""
    from terrain_odom.kinematics import compose

    last = a.pose[np.flatnonzero(a.has_pose)[-1]]
    pose_b = compose(np.broadcast_to(last, b.pose.shape), b.pose)
    return WheelLog(
        np.r_[a.t, a.t[-1] + 0.05 + b.t], np.r_[a.v_l, b.v_l], np.r_[a.v_r, b.v_r],
        np.r_[a.pose, pose_b], np.r_[a.terrain, b.terrain], np.zeros(len(a) + len(b), int),
    )  # fmt: skip


def test_sigma_weights_the_loss():
    segs = _segments([constant_model_log("edd-sym", TRUTH["edd-sym"], seconds=20.0)])
    m = get_model("edd-sym")
    p = np.array([[0.8, 2.0]])
    base = residuals(m, p, segs)
    from terrain_odom.fitting.loss import whitener_matrix

    scaled = residuals(m, p, segs, whitener=whitener_matrix([2.0, 2.0, 0.5]))
    np.testing.assert_allclose(scaled, base * [0.5, 0.5, 2.0])
    with pytest.raises(ValueError, match="positive definite|> 0"):
        whitener_matrix([1.0, 0.0, 1.0])


def test_idd_has_nothing_to_fit():
    segs = _segments([constant_model_log("idd", [], seconds=20.0, track_width=1.0)])
    result = fit_model("idd", segs, track_width=1.0)
    assert result.params.size == 0 and result.loss < 1e-3


def test_no_segment_is_an_error():
    log = constant_model_log("edd-sym", TRUTH["edd-sym"], seconds=2.0)
    with pytest.raises(ValueError, match="no training segment"):
        fit_model("edd-sym", _segments([log], Horizon(50.0, "m")))


@pytest.mark.parametrize("text", ["2x", "-2m", "0s", "m", "2 mm", ""])
def test_malformed_horizon(text):
    with pytest.raises(ValueError, match="horizon"):
        parse_horizon(text)
