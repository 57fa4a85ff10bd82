"""A simulated run: the map, the true motion, the noisy sensors, the frames.

Deterministic for a given seed: one :class:`numpy.random.SeedSequence` per
seed is split into independent streams (map tiling, encoders, poses,
lighting, frame noise, training patches), so e.g. rendering fewer frames
does not change the wheel log.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from dataclasses import dataclass

import cv2
import numpy as np

from terrain_odom.config import CameraConfig, RobotConfig
from terrain_odom.sim.render import Renderer
from terrain_odom.sim.robot import Motion, drive, encoder_speeds, pose_measurements
from terrain_odom.sim.scenarios import Scenario
from terrain_odom.sim.world import GroundMap, build_map
from terrain_odom.vision.camera import GroundCamera

__all__ = ["Simulation", "Patch", "simulate", "frame_rows", "iter_frames", "sample_patches"]

_STREAMS = ("map", "encoder", "pose", "lighting", "frames", "patches")


@dataclass
class Simulation:
    """Everything a simulated run produced except the images.

    Attributes
    ----------
    scenario : Scenario
        The scenario, with the camera and robot actually used.
    seed : int
    ground : GroundMap
    motion : Motion
        Truth at every wheel sample.
    v_l, v_r : ndarray, shape (N,)
        Measured (noisy) track speeds, m/s.
    measured_pose : ndarray, shape (N, 3)
        GPS-like poses, NaN rows without a measurement.
    renderer : Renderer
    """

    scenario: Scenario
    seed: int
    ground: GroundMap
    motion: Motion
    v_l: np.ndarray
    v_r: np.ndarray
    measured_pose: np.ndarray
    renderer: Renderer

    def rng(self, stream: str) -> np.random.Generator:
        """Return a fresh generator for one of the named random streams of this seed."""
        return _rng(self.seed, stream)


def _rng(seed: int, stream: str) -> np.random.Generator:
    """Return a fresh generator for the stream ``stream`` (one of ``_STREAMS``) of ``seed``."""
    children = np.random.SeedSequence(seed).spawn(len(_STREAMS))
    return np.random.default_rng(children[_STREAMS.index(stream)])


def _with_geometry(
    scenario: Scenario, robot: RobotConfig | None, camera: CameraConfig | None
) -> Scenario:
    """Replace the scenario's robot (scaling its ICR table) and camera."""
    if camera is not None:
        scenario = dataclasses.replace(scenario, camera=camera)
    if robot is not None:
        factor = robot.track_width / scenario.robot.track_width
        table = {k: p.scaled(factor) for k, p in scenario.table.items()}
        scenario = dataclasses.replace(scenario, robot=robot, table=table)
    return scenario


def simulate(
    scenario: Scenario,
    seed: int = 0,
    *,
    robot: RobotConfig | None = None,
    camera: CameraConfig | None = None,
) -> Simulation:
    """Simulate a scenario: build the map, drive, add sensor noise.

    Parameters
    ----------
    scenario : Scenario
    seed : int
        Seeds every random draw.
    robot : RobotConfig, optional
        Replaces the scenario's robot; the terrain ICRs scale with its track width.
    camera : CameraConfig, optional
        Replaces the scenario's camera.

    Returns
    -------
    Simulation
    """
    scenario = _with_geometry(scenario, robot, camera)
    ground = build_map(scenario.map, _rng(seed, "map"))
    motion = drive(
        ground,
        scenario.table,
        scenario.make_driver(),
        duration=scenario.duration,
        rate=scenario.wheel_rate,
        start=scenario.start,
    )
    v_l, v_r = encoder_speeds(motion, scenario.sigma_encoder, _rng(seed, "encoder"))
    every = int(round(scenario.wheel_rate / scenario.pose_rate))
    measured = pose_measurements(
        motion, every, scenario.sigma_xy, scenario.sigma_yaw, _rng(seed, "pose"), scenario.mounting
    )
    phase = float(_rng(seed, "lighting").uniform(0.0, 2.0 * np.pi))
    lighting = dataclasses.replace(scenario.lighting, phase=phase)
    renderer = Renderer(ground, GroundCamera(scenario.camera), lighting)
    return Simulation(scenario, seed, ground, motion, v_l, v_r, measured, renderer)


def frame_rows(sim: Simulation) -> np.ndarray:
    """Return the indices of the wheel samples at which frames are taken."""
    every = int(round(sim.scenario.wheel_rate / sim.scenario.frame_rate))
    return np.arange(0, sim.motion.t.size, every)


def iter_frames(sim: Simulation) -> Iterator[tuple[float, np.ndarray]]:
    """Yield ``(t, RGB frame)`` for every frame of the run, in time order."""
    rng = sim.rng("frames")
    for k in frame_rows(sim):
        t = float(sim.motion.t[k])
        yield t, sim.renderer.render(sim.motion.pose[k], t, rng)


def _path_mask(sim: Simulation) -> np.ndarray:
    """Map pixels within ``patch_margin`` of the driven path."""
    ground = sim.ground
    mask = np.zeros(ground.labels.shape, dtype=np.uint8)
    pts = np.rint(ground.world_to_pixel(sim.motion.pose[:, :2]) * 16).astype(np.int32)
    thickness = max(1, int(round(2.0 * sim.scenario.patch_margin / ground.resolution)))
    cv2.polylines(mask, [pts], False, 1, thickness=thickness, lineType=cv2.LINE_8, shift=4)
    return mask.astype(bool)


def _crop_terrain(sim: Simulation, pose: np.ndarray, corner: np.ndarray, mask: np.ndarray) -> int:
    """Terrain index seen by the whole crop at ``corner`` (u0, v0), or -1 if mixed or driven over."""
    size = sim.scenario.patch_size
    grid = np.linspace(0.0, size - 1.0, 5)
    uv = np.stack(np.meshgrid(grid + corner[0], grid + corner[1]), axis=-1).reshape(-1, 2)
    points = sim.renderer.ground_points(uv, pose)
    if not np.isfinite(points).all():
        return -1
    labels = sim.ground.label_index(points)
    if labels.min() < 0 or labels.min() != labels.max():
        return -1
    pix = np.rint(sim.ground.world_to_pixel(points)).astype(int)
    return -1 if mask[pix[:, 1], pix[:, 0]].any() else int(labels[0])


@dataclass(frozen=True)
class Patch:
    """A labelled training patch.

    Attributes
    ----------
    terrain : str
    image : ndarray, shape (S, S, 3), uint8
        RGB crop of a rendered frame.
    pose : ndarray, shape (3,)
        Robot pose the frame was rendered from (m, m, rad).
    corner : tuple of 2 int
        Top-left pixel ``(u0, v0)`` of the crop in that frame.
    """

    terrain: str
    image: np.ndarray
    pose: np.ndarray
    corner: tuple[int, int]


def sample_patches(sim: Simulation, max_tries: int = 20000) -> list[Patch]:
    """Labelled training patches rendered through the run's camera.

    Random robot poses over the map; a ``patch_size`` crop of the frame is
    kept when all the ground it sees (a 5 x 5 grid of its pixels) is one
    terrain, on the map, and farther than ``patch_margin`` from the driven
    path. Frames get the run's lighting (at a random time) and noise.

    Returns
    -------
    list of Patch
        Up to ``patches_per_terrain`` per terrain, in the order drawn.
    """
    sc, ground = sim.scenario, sim.ground
    rng, mask = sim.rng("patches"), _path_mask(sim)
    want = sc.patches_per_terrain
    counts = dict.fromkeys(ground.terrains, 0)
    patches: list[Patch] = []
    x_min, x_max, y_min, y_max = ground.extent
    cam = sim.renderer.camera
    for _ in range(max_tries):
        if all(n >= want for n in counts.values()):
            break
        pose = np.array([rng.uniform(x_min, x_max), rng.uniform(y_min, y_max), 0.0])
        pose[2] = rng.uniform(-np.pi, np.pi)
        corner = rng.integers(0, (cam.width - sc.patch_size + 1, cam.height - sc.patch_size + 1))
        index = _crop_terrain(sim, pose, corner, mask)
        if index < 0 or counts[ground.terrains[index]] >= want:
            continue
        name = ground.terrains[index]
        frame = sim.renderer.render(pose, float(rng.uniform(0.0, sc.duration)), rng)
        u0, v0 = int(corner[0]), int(corner[1])
        crop = frame[v0 : v0 + sc.patch_size, u0 : u0 + sc.patch_size].copy()
        patches.append(Patch(name, crop, pose, (u0, v0)))
        counts[name] += 1
    return patches
