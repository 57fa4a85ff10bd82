"""``estimation/terrain.py``: confirming a change, and the arrival rule.

``TerrainTracker``'s confirmation counts and ``steady`` are stated as
properties (written for mutants no test killed, docs/testing.md); the arrival
rule through the model's speed, the log odometer, and the stream applying it alike.
"""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.config import Config
from terrain_odom.estimation.online import OnlineOdometry
from terrain_odom.estimation.terrain import Odometer, TerrainTracker, model_speed
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


# --- TerrainTracker: a change confirmed after `confirm` consecutive observations
def test_steady_only_on_the_current_label_with_no_candidate_pending():
    tracker = TerrainTracker(confirm=3)
    tracker.observe("grass")
    assert tracker.steady("grass")
    assert not tracker.steady("sand")  # another label would start a candidate
    tracker.observe("sand")  # a candidate is pending: the next "grass" clears it
    assert not tracker.steady("grass") and not tracker.steady("sand")
    tracker.observe("grass")
    assert tracker.steady("grass") and not tracker.steady("sand")


def test_a_fresh_tracker_is_steady_on_no_label():
    tracker = TerrainTracker()
    assert not tracker.steady("grass")  # the first observation sets the terrain


@pytest.mark.parametrize("confirm", [1, 2, 3, 5])
def test_a_change_needs_exactly_confirm_observations_after_an_interruption(confirm):
    tracker = TerrainTracker(confirm=confirm)
    tracker.observe("grass")
    # a candidate interrupted by the current label starts again from nothing
    for _ in range(confirm - 1):
        assert tracker.observe("sand") is None
    assert tracker.observe("grass") is None
    seen = [tracker.observe("sand", at=float(k)) for k in range(confirm)]
    assert seen == [None] * (confirm - 1) + ["sand"]
    assert tracker.current == "sand" and tracker.changed_at == 0.0
    # after a confirmed change the count starts again from nothing too
    seen = [tracker.observe("mud", at=10.0 + k) for k in range(confirm)]
    assert seen == [None] * (confirm - 1) + ["mud"]
    assert tracker.changed_at == 10.0


def test_confirm_below_one_is_refused():
    with pytest.raises(ValueError, match="confirm must be >= 1, got 0"):
        TerrainTracker(confirm=0)


def test_by_default_a_change_is_confirmed_on_its_second_observation():
    tracker = TerrainTracker()
    assert tracker.changed_at is None  # no change yet, not even after the first label
    tracker.observe("grass", at=0.0)
    assert tracker.changed_at is None and tracker.current == "grass"
    assert [tracker.observe("sand", at=t) for t in (1.0, 2.0)] == [None, "sand"]
    assert tracker.changed_at == 1.0
