"""Shared fixtures of the app-layer tests: one short simulated run, written once."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from terrain_odom.app.simulate import SimOutput, write_simulation
from terrain_odom.sim import get_scenario, simulate


@pytest.fixture(scope="session")
def sim_output(tmp_path_factory: pytest.TempPathFactory) -> SimOutput:
    """Return a 30-s chen2023 run (grass, then gravel), written without frames or patches."""
    scenario = dataclasses.replace(get_scenario("chen2023"), duration=30.0)
    out: Path = tmp_path_factory.mktemp("sim")
    return write_simulation(simulate(scenario, seed=3), out, frames=False, patches=False)
