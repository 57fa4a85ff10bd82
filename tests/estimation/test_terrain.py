"""The arrival rule: the model's speed, the log odometer, and the stream applying it alike."""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.config import Config
from terrain_odom.estimation.online import OnlineOdometry
from terrain_odom.estimation.terrain import Odometer, model_speed
from terrain_odom.records import Sighting, WheelLog


def _log(t: np.ndarray, v_l: np.ndarray, v_r: np.ndarray, segment: np.ndarray | None) -> WheelLog:
    segment = np.zeros(t.size, dtype=int) if segment is None else segment
    return WheelLog(t, v_l, v_r, np.full((t.size, 3), np.nan), None, segment)


def _straight_log(t: np.ndarray, speed: float, segment: np.ndarray | None = None) -> WheelLog:
    return _log(t, np.full(t.size, speed), np.full(t.size, speed), segment)


def test_model_speed_known_answers() -> None:
    """Straight: the track speed whatever the ICRs; a spin: |omega x_icr|, scaled by alpha."""
    assert model_speed(0.5, 0.5, np.array([0.3, -0.4, 0.2])) == pytest.approx(0.5)
    spin = np.array([0.4, -0.4, 0.2])  # omega = 1 / 0.8 rad/s, v_x = 0
    assert model_speed(-0.5, 0.5, spin) == pytest.approx(0.25)
    assert model_speed(-0.5, 0.5, np.r_[spin, 0.8]) == pytest.approx(0.2)
    rows = model_speed(np.array([0.5, -0.5]), np.array([0.5, 0.5]), np.tile(spin, (2, 1)).T)
    assert rows == pytest.approx([0.5, 0.25])


def test_odometer_arrival_known_answers() -> None:
    """Straight at 0.5 m/s (ICRs of any width, x_icr 0): 1 m ahead is reached 2 s later."""
    t = np.arange(0.0, 10.0, 0.1)
    states = np.tile([0.0, 0.0, 0.0, 0.3, -0.3, 0.0], (t.size, 1))
    odometer = Odometer(_straight_log(t, 0.5), states)
    assert odometer.arrival(31, 3.15, 1.0) == pytest.approx(5.15)
    assert odometer.arrival(31, 3.15, 0.0) == 3.15
    assert odometer.arrival(90, 9.0, 1.0) is None  # the log ends first
    segment = (t >= 4.0).astype(int)
    broken = Odometer(_straight_log(t, 0.5, segment), states)
    assert broken.arrival(31, 3.15, 1.0) is None  # the segment ends first
    assert broken.arrival(41, 4.1, 1.0) == pytest.approx(6.1)


def test_the_stream_applies_a_change_where_the_log_odometer_arrives() -> None:
    """One arrival rule: the stream applies a change where the log odometer arrives.

    A change seen 1.3 m ahead at row 30 of a curving drive is applied at the
    first wheel sample at or after the time :meth:`Odometer.arrival` gives.
    """
    t = np.arange(0.0, 12.0, 0.1)
    v_l, v_r = 0.4 + 0.2 * np.sin(t), 0.6 + 0.1 * np.cos(0.7 * t)
    odo = OnlineOdometry(Config())
    states = []
    for k, t_k in enumerate(t):
        odo.wheels(float(t_k), float(v_l[k]), float(v_r[k]))
        if k == 0:
            odo.sighting(0.0, Sighting("grass"))
        if k == 30:
            for _ in range(Config().terrain.confirm):
                odo.sighting(3.0, Sighting("gravel", 1.3))
        states.append(odo.estimate()[0])
    reached = Odometer(_log(t, v_l, v_r, None), np.array(states)).arrival(30, 3.0, 1.3)
    assert reached is not None and 4.0 < reached < 10.0
    assert np.min(np.abs(t - reached)) > 1e-3  # the sample the change falls on is unambiguous
    [change] = odo.changes
    assert (change.previous, change.label) == ("grass", "gravel")
    assert change.t == pytest.approx(t[t >= reached][0])
