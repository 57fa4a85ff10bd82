"""Tests of :class:`terrain_odom.app.simulate.SimOutput`: the typed result of ``write_simulation``."""

from __future__ import annotations

import dataclasses
import json

import pytest

from terrain_odom.app.simulate import SimOutput


def test_to_dict_is_what_simulation_json_holds(sim_output: SimOutput) -> None:
    on_disk = json.loads(sim_output.metadata_json.read_text(encoding="utf-8"))

    assert on_disk == json.loads(json.dumps(sim_output.to_dict()))
    assert on_disk["command"] == "simulate"
    assert on_disk["counts"] == {
        "rows": sim_output.rows,
        "pose_rows": sim_output.pose_rows,
        "frames": 0,
        "patches": {},
    }
    assert on_disk["map"]["preview"]["file"] == sim_output.map_preview.name == "map.png"


def test_paths_and_counts(sim_output: SimOutput) -> None:
    assert sim_output.frames_csv is None and sim_output.patches_dir is None
    assert sim_output.log_csv.is_file() and sim_output.groundtruth_csv.is_file()
    assert sim_output.map_preview.is_file()
    assert 0 < sim_output.pose_rows < sim_output.rows
    assert sim_output.map_preview_resolution >= sim_output.simulation.ground.resolution


def test_is_frozen(sim_output: SimOutput) -> None:
    with pytest.raises(dataclasses.FrozenInstanceError):
        sim_output.frames = 3  # type: ignore[misc]  # the assignment under test
