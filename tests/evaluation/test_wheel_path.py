"""The wheel path and the windows' least squares, on paths with known answers."""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.evaluation.robust import MAD_TO_STD, correlation_time
from terrain_odom.evaluation.wheel_path import (
    Fixes,
    Track,
    fit_windows,
    ideal_yaw,
    run_time,
    wheel_track,
    window_fixes,
)
from terrain_odom.records import WheelLog


def _log(t: np.ndarray, segment: np.ndarray, v_l=None, v_r=None) -> WheelLog:
    n = t.size
    v_l = np.ones(n) if v_l is None else v_l
    v_r = np.ones(n) if v_r is None else v_r
    return WheelLog(t, v_l, v_r, np.zeros((n, 3)), None, segment)


def test_run_time_keeps_each_run_and_jumps_far_between_them():
    t = np.r_[np.arange(5.0), np.arange(5.0)]  # the second run starts again at 0 s
    time = run_time(_log(t, np.r_[np.zeros(5, int), np.ones(5, int)]))
    np.testing.assert_array_equal(np.diff(time[:5]), 1.0)
    np.testing.assert_array_equal(np.diff(time[5:]), 1.0)
    assert time[5] - time[4] == pytest.approx(1e6)


def test_window_fixes_keeps_windows_with_enough_fixes_over_half_their_length():
    t = np.r_[0.0:10.0:1.0, 10.0, 11.0, 12.0, 20.0:24.9:0.5]  # full; three fixes; 4.5 s of 10
    log = _log(t, np.zeros(t.size, int))
    log.pose[:, :2] = np.c_[t, -t]
    fixes = window_fixes(log, t, 10.0, 5)
    np.testing.assert_array_equal(fixes.t, np.arange(10.0))  # only the first window is kept
    np.testing.assert_array_equal(fixes.window, 0)
    np.testing.assert_array_equal(fixes.m, t[:10] - 1j * t[:10])
    # windows of 8 s: [0, 8) 8 fixes; [8, 16) 5 fixes over 4 s; [16, 24) 8 over 3.5 s; [24, 32) 2
    eight = window_fixes(log, t, 8.0, 5)
    np.testing.assert_array_equal(eight.t, t[:13])
    np.testing.assert_array_equal(eight.window, np.r_[np.zeros(8), np.ones(5)])
    np.testing.assert_array_equal(window_fixes(log, t, 8.0, 6).t, t[:8])


def test_ideal_yaw_and_wheel_path_of_a_circle():
    """Tracks at 0.5 and 1.5 m/s, 1 m apart: 1 rad/s on a 1-m circle."""
    t = np.linspace(0.0, np.pi, 2001)
    log = _log(t, np.zeros(t.size, int), np.full(t.size, 0.5), np.full(t.size, 1.5))
    psi = ideal_yaw(log, t, 1.0)
    np.testing.assert_allclose(psi, t, atol=1e-12)
    track = wheel_track(log, t, psi)
    np.testing.assert_allclose(track.q, 1j * (1.0 - np.exp(1j * t)), atol=1e-6)


def test_fit_windows_recovers_the_windows_similarities_and_the_lever_arm():
    """Positions made from the wheel path exactly: every window's c_w and the lever arm back."""
    t = np.arange(6000) * 0.01
    psi = 0.8 * np.sin(0.5 * t) + 0.3 * np.sin(1.7 * t)  # turning unevenly
    q = np.r_[0.0, np.cumsum(np.exp(1j * 0.5 * (psi[1:] + psi[:-1])) * np.diff(t))]
    track = Track(t, q, psi)
    rows = np.arange(0, t.size, 20)
    window = (t[rows] // 10.0).astype(int)
    c_w = np.exp(1j * (0.2 + 0.1 * np.arange(6))) * (1.0 + 0.01 * np.arange(6))
    shift = 3.0 * np.arange(6) - 2j
    antenna = 0.6 - 0.25j
    theta = psi[rows] + np.angle(c_w[window])
    m = c_w[window] * q[rows] + shift[window] + np.exp(1j * theta) * antenna
    fit = fit_windows(track, Fixes(t[rows], m, window), 0.0, lever=True, rounds=5)
    assert fit.a == pytest.approx(antenna, abs=1e-6)
    np.testing.assert_allclose(fit.c, c_w, atol=1e-6)
    assert fit.cost < 1e-9
    plain = fit_windows(track, Fixes(t[rows], m, window), 0.0, lever=False)
    assert plain.cost > 1e3 * fit.cost  # without the lever arm the positions do not fit


def test_robust_scale_and_correlation_time_of_known_samples():
    rng = np.random.default_rng(0)
    x = rng.normal(0.0, 2.0, 200_000)
    assert MAD_TO_STD * np.median(np.abs(x)) == pytest.approx(2.0, rel=0.01)
    assert correlation_time(rng.normal(size=20_000)) == pytest.approx(1.0, abs=0.1)
    ar = np.zeros(50_000)  # AR(1), phi 0.8: integrated time (1 + phi) / (1 - phi) = 9
    noise = rng.normal(size=ar.size)
    for k in range(1, ar.size):
        ar[k] = 0.8 * ar[k - 1] + noise[k]
    assert correlation_time(ar) == pytest.approx(9.0, rel=0.15)
