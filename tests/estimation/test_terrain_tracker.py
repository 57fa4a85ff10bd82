"""``TerrainTracker``: confirmation counts and ``steady`` stated as properties.

Written for the mutants of ``estimation/terrain.py`` that no test killed
(docs/testing.md): ``steady`` was exercised only through the streaming API's
fast path, and a count restarting at 1 instead of 0 only by a timeout.
"""

from __future__ import annotations

import pytest

from terrain_odom.estimation.terrain import TerrainTracker


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
