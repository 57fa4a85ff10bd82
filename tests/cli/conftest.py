"""Fixtures of the command-line tests: simulated recordings, each made once per set of arguments."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from terrain_odom.app.simulate import write_simulation
from terrain_odom.sim import TERRAIN_TABLE, Simulation, get_scenario, simulate


@dataclass(frozen=True)
class Recording:
    """A simulated recording: the simulation, and the folder it was written to (if asked)."""

    sim: Simulation
    folder: Path | None


Recorder = Callable[..., Recording]


@pytest.fixture(scope="session")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Recorder:
    """Return a factory of simulated recordings, each simulated (and written) once per session.

    ``recording(duration, seed=..., scenario="chen2023", terrain=None, write=False,
    frames=False, **changes)``: ``scenario`` driven for ``duration`` s with
    ``seed``; ``changes`` are its other fields (``pose_rate``, ``frame_rate``
    Hz; ``sigma_xy`` m, ``sigma_yaw`` rad; ``antenna`` m; ``heading_offset``
    rad); ``terrain`` one terrain's parameters everywhere. ``write``: the
    folder ``terrain-odom simulate --no-patches`` writes (``--no-frames``
    unless ``frames``). The same arguments give the same recording: tests
    only read it.
    """
    made: dict[tuple, Recording] = {}

    def make(
        duration: float,
        *,
        seed: int,
        scenario: str = "chen2023",
        terrain: str | None = None,
        write: bool = False,
        frames: bool = False,
        **changes: Any,
    ) -> Recording:
        key = (duration, seed, scenario, terrain, write, frames, tuple(sorted(changes.items())))
        if key not in made:
            if terrain is not None:
                changes["table"] = dict.fromkeys(TERRAIN_TABLE, TERRAIN_TABLE[terrain])
            chosen = dataclasses.replace(get_scenario(scenario), duration=duration, **changes)
            sim = simulate(chosen, seed)
            folder = None
            if write:
                folder = tmp_path_factory.mktemp(scenario) / "sim"
                write_simulation(sim, folder, frames=frames, patches=False)
            made[key] = Recording(sim, folder)
        return made[key]

    return make
