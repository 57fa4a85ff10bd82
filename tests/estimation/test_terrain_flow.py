"""``TerrainFlow`` with a stand-in filter: ``steady``, and changes recorded without adaptation.

Written for mutants of ``estimation/terrain.py`` no test killed
(docs/testing.md): the recorded change of a run with ``terrain.adapt`` off
(its time, terrains and flags) and ``steady`` before and after the first terrain.
"""

from __future__ import annotations

import dataclasses

from terrain_odom.config import Config
from terrain_odom.estimation.terrain import TerrainFlow
from terrain_odom.records import Sighting, TerrainChange


class _Filter:
    """The part of a filter the flow uses, recording what it was asked to do."""

    def __init__(self) -> None:
        self.t = 0.0
        self.terrain: str | None = None
        self.resets: list[str] = []

    def set_terrain(self, label: str) -> None:
        self.terrain = label

    def reset_on_terrain_change(self, label: str) -> TerrainChange:
        self.resets.append(label)
        change = TerrainChange(self.t, self.terrain, label, restored=False)
        self.terrain = label
        return change


def _flow(adapt: bool) -> tuple[TerrainFlow, _Filter]:
    cfg = Config()
    terrain = dataclasses.replace(cfg.terrain, adapt=adapt, confirm=2, reset_at="immediate")
    ekf = _Filter()
    return TerrainFlow(ekf, dataclasses.replace(cfg, terrain=terrain)), ekf


def test_without_adaptation_a_change_is_recorded_not_reset():
    flow, ekf = _flow(adapt=False)
    flow.observe(Sighting("grass"))
    ekf.t = 4.5
    flow.observe(Sighting("sand"))
    assert flow.changes == []  # one sighting confirms nothing
    ekf.t = 5.0
    flow.observe(Sighting("sand"))
    assert flow.changes == [TerrainChange(5.0, "grass", "sand", restored=False, reset=False)]
    assert ekf.terrain == "sand" and ekf.resets == []


def test_with_adaptation_the_filter_resets():
    flow, ekf = _flow(adapt=True)
    for label in ("grass", "sand", "sand"):
        flow.observe(Sighting(label))
    assert ekf.resets == ["sand"] and flow.changes == [TerrainChange(0.0, "grass", "sand", False)]


def test_steady_once_the_filter_has_a_terrain_and_the_label_is_it():
    flow, _ = _flow(adapt=True)
    assert flow.steady(None)  # no label changes nothing
    assert not flow.steady(Sighting("grass"))  # the first label names the terrain
    flow.observe(Sighting("grass"))
    assert flow.ekf.terrain == "grass" and flow.seen == "grass"
    assert flow.steady(Sighting("grass")) and not flow.steady(Sighting("sand"))


def _arrival_flow() -> tuple[TerrainFlow, _Filter]:
    cfg = Config()
    terrain = dataclasses.replace(cfg.terrain, confirm=2, reset_at="arrival")
    ekf = _Filter()
    return TerrainFlow(ekf, dataclasses.replace(cfg, terrain=terrain)), ekf


def test_a_change_reached_later_records_when_it_was_confirmed():
    flow, ekf = _arrival_flow()
    flow.observe(Sighting("grass", 1.0))
    ekf.t = 2.0
    for _ in range(2):  # confirmed at t = 2 s, on ground 1 m ahead
        flow.observe(Sighting("sand", 1.0))
    assert flow.changes == [] and len(flow.pending) == 1
    flow.travel(0.99)
    flow.apply_reached()
    assert flow.changes == []  # not there yet
    ekf.t = 3.0
    flow.travel(0.01)
    flow.apply_reached()
    assert flow.changes == [TerrainChange(3.0, "grass", "sand", False, t_confirmed=2.0)]


def test_a_change_reached_when_it_is_confirmed_has_no_earlier_confirmation():
    flow, ekf = _arrival_flow()
    flow.observe(Sighting("grass", 1.0))
    ekf.t = 2.0
    for _ in range(2):
        flow.observe(Sighting("sand", 1.0))
    flow.travel(1.0)  # reached with no filter time passing: t_confirmed is not earlier than t
    flow.apply_reached()
    assert flow.changes == [TerrainChange(2.0, "grass", "sand", False)]
    assert flow.changes[0].t_confirmed is None


def test_a_change_reached_at_once_waits_behind_an_earlier_pending_one():
    flow, ekf = _arrival_flow()
    flow.observe(Sighting("grass", 1.0))
    for _ in range(2):  # sand 1 m ahead: pending
        flow.observe(Sighting("sand", 1.0))
    ekf.t = 0.5
    for _ in range(2):  # mud under the robot: reached already, but sand comes first
        flow.observe(Sighting("mud", 0.0))
    assert flow.changes == [] and [p[1] for p in flow.pending] == ["sand", "mud"]
    ekf.t = 1.0
    flow.travel(1.0)
    flow.apply_reached()
    assert [(c.previous, c.label) for c in flow.changes] == [("grass", "sand"), ("sand", "mud")]
    assert [c.t_confirmed for c in flow.changes] == [0.0, 0.5] and ekf.terrain == "mud"
