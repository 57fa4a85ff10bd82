"""Simulator of terrain-aware skid-steer runs with ground truth.

A ground map of terrain regions textured with real photos (scikit-image's
grass, gravel and brick), a skid-steer robot whose true motion follows
terrain-dependent ICRs and slip, noisy encoders and GPS-like poses, and a
ground camera rendered by warping the map through the camera model. See
:func:`simulate` (written to disk by :func:`terrain_odom.app.simulate.write_simulation`); scenarios in
:mod:`terrain_odom.sim.scenarios`.

Examples
--------
>>> from terrain_odom.sim import get_scenario, simulate
>>> import dataclasses
>>> sc = dataclasses.replace(get_scenario("chen2023"), duration=2.0)
>>> sim = simulate(sc, seed=1)
>>> sim.motion.t.size, str(sim.motion.terrain[0])
(100, 'grass')
"""

from terrain_odom.sim.render import Lighting, Renderer, frame_homography
from terrain_odom.sim.robot import Motion, TerrainParams, drive
from terrain_odom.sim.scenarios import SCENARIOS, TERRAIN_TABLE, Scenario, get_scenario
from terrain_odom.sim.simulation import Patch, Simulation, iter_frames, sample_patches, simulate
from terrain_odom.sim.world import GroundMap, MapSpec, Region, build_map

__all__ = [
    "SCENARIOS",
    "TERRAIN_TABLE",
    "GroundMap",
    "Lighting",
    "MapSpec",
    "Motion",
    "Patch",
    "Region",
    "Renderer",
    "Scenario",
    "Simulation",
    "TerrainParams",
    "build_map",
    "drive",
    "frame_homography",
    "get_scenario",
    "iter_frames",
    "sample_patches",
    "simulate",
]
