"""Tests of the simulator (:mod:`terrain_odom.sim`)."""

from __future__ import annotations

import csv
import dataclasses
from pathlib import Path

import cv2
import numpy as np
import pytest

from terrain_odom.app.simulate import write_simulation
from terrain_odom.config import CameraConfig, RobotConfig, load_config
from terrain_odom.io import read_trajectory_csv, read_wheel_log
from terrain_odom.kinematics import integrate, twist_icr, wrap_angle
from terrain_odom.sim import (
    TERRAIN_TABLE,
    GroundMap,
    Lighting,
    MapSpec,
    Region,
    Renderer,
    build_map,
    get_scenario,
    simulate,
)
from terrain_odom.sim.scenarios import SIM_CAMERA
from terrain_odom.vision.camera import GroundCamera

SMALL_CAMERA = dataclasses.replace(
    SIM_CAMERA, width=160, height=120, fx=100.0, fy=100.0, cx=79.5, cy=59.5
)


def _box(x0, x1, y0, y1):
    return ((x0, y0), (x1, y0), (x1, y1), (x0, y1))


def small_scenario(**changes):
    """chen2023 on a small, coarse map: grass then gravel after ~4 s; brick off the path."""
    spec = MapSpec(
        extent=(4.0, 14.0, -3.0, 3.0),
        resolution=0.02,
        base="grass",
        regions=(
            Region("gravel", _box(8.0, 16.5, -3.0, 3.0)),
            Region("brick", _box(10.0, 14.0, 1.5, 3.0)),
        ),
    )
    base = dataclasses.replace(
        get_scenario("chen2023"),
        map=spec,
        start=(6.0, 0.0, 0.0),
        duration=6.0,
        frame_rate=5.0,
        camera=SMALL_CAMERA,
        patch_size=32,
        patches_per_terrain=3,
        patch_margin=0.5,
    )
    return dataclasses.replace(base, **changes)


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("sim") / "run"
    sim = simulate(small_scenario(), seed=5)
    write_simulation(sim, out)
    return sim, out


def _files(folder: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()
    }


def test_same_seed_gives_identical_files_and_another_seed_does_not(run_dir, tmp_path):
    _, out = run_dir
    write_simulation(simulate(small_scenario(), seed=5), tmp_path / "again")
    write_simulation(simulate(small_scenario(), seed=6), tmp_path / "other")
    first = _files(out)
    assert first == _files(tmp_path / "again")
    other = _files(tmp_path / "other")
    assert other.keys() == first.keys()
    assert other["log.csv"] != first["log.csv"]
    assert other["frames/000000.png"] != first["frames/000000.png"]


def test_groundtruth_obeys_the_icr_kinematics_with_the_terrain_table(run_dir):
    _, out = run_dir
    gt = read_trajectory_csv(out / "groundtruth.csv")
    with (out / "groundtruth.csv").open(newline="") as handle:
        terrain = [row["terrain"] for row in csv.DictReader(handle)]
    assert {"grass", "gravel"} <= set(terrain)  # the run crosses a terrain change
    table = np.array([dataclasses.astuple(TERRAIN_TABLE[name]) for name in terrain])
    params = np.column_stack([gt["y_l"], gt["y_r"], gt["x_icr"], gt["alpha"]])
    np.testing.assert_array_equal(params, table)
    twist = twist_icr(gt["v_l"], gt["v_r"], *table.T)
    start = [gt["x"][0], gt["y"][0], gt["yaw"][0]]
    poses = integrate(*(c[:-1] for c in twist), np.diff(gt["t"]), start=start)
    np.testing.assert_allclose(poses[:, 0], gt["x"], atol=1e-9)
    np.testing.assert_allclose(poses[:, 1], gt["y"], atol=1e-9)
    np.testing.assert_allclose(wrap_angle(poses[:, 2] - gt["yaw"]), 0.0, atol=1e-9)


def test_log_speeds_are_the_true_ones_plus_zero_mean_noise(run_dir):
    sim, out = run_dir
    log = read_wheel_log(out / "log.csv")
    gt = read_trajectory_csv(out / "groundtruth.csv")
    np.testing.assert_array_equal(log.t, gt["t"])
    sigma = sim.scenario.sigma_encoder
    noise = np.concatenate([log.v_l - gt["v_l"], log.v_r - gt["v_r"]])
    assert abs(noise.mean()) < 4.0 * sigma / np.sqrt(noise.size)
    assert 0.8 * sigma < noise.std() < 1.2 * sigma
    assert abs(log.v_l.mean() - gt["v_l"].mean()) < 4.0 * sigma / np.sqrt(log.t.size)


def test_wheel_log_reads_back_with_poses_at_the_configured_rate(run_dir):
    sim, out = run_dir
    log = read_wheel_log(out / "log.csv")
    sc = sim.scenario
    assert log.t.size == round(sc.duration * sc.wheel_rate)
    measured = np.flatnonzero(np.isfinite(log.pose[:, 0]))
    np.testing.assert_array_equal(measured, np.arange(0, log.t.size, sc.wheel_rate / sc.pose_rate))
    error = log.pose[measured, :2] - sim.motion.pose[measured, :2]
    assert 0.5 * sc.sigma_xy < error.std() < 1.5 * sc.sigma_xy
    np.testing.assert_array_equal(log.terrain, sim.motion.terrain)


def test_frames_csv_lists_existing_frames_of_the_camera_size(run_dir):
    sim, out = run_dir
    with (out / "frames.csv").open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == sim.scenario.duration * sim.scenario.frame_rate
    times = np.array([float(r["t"]) for r in rows])
    np.testing.assert_allclose(np.diff(times), 1.0 / sim.scenario.frame_rate)
    for row in rows:
        image = cv2.imread(str(out / row["file"]))
        assert image is not None and image.shape == (120, 160, 3)


def test_patches_are_labelled_folders_of_the_patch_size(run_dir):
    _, out = run_dir
    folders = sorted(p.name for p in (out / "patches").iterdir())
    assert folders == ["brick", "grass", "gravel"]
    for name in folders:
        files = sorted((out / "patches" / name).glob("*.png"))
        assert len(files) == 3
        assert cv2.imread(str(files[0])).shape == (32, 32, 3)


def test_patches_see_no_ground_near_the_driven_path_and_only_their_terrain(run_dir):
    sim, out = run_dir
    with (out / "patches.csv").open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == 9 and all((out / r["file"]).is_file() for r in rows)
    size, path = sim.scenario.patch_size, sim.motion.pose[:, :2]
    grid = np.linspace(0.0, size - 1.0, 7)
    for row in rows:
        pose = [float(row[k]) for k in ("x", "y", "yaw")]
        uv = np.stack(np.meshgrid(grid + int(row["u0"]), grid + int(row["v0"])), -1).reshape(-1, 2)
        seen = sim.renderer.ground_points(uv, pose)
        assert set(sim.ground.terrain_at(seen).tolist()) == {row["terrain"]}
        distance = np.hypot(*(seen[:, None, :] - path[None]).transpose(2, 0, 1)).min()
        assert distance > sim.scenario.patch_margin - 0.05


def test_config_yaml_of_the_run_loads_with_its_camera_and_robot(run_dir):
    sim, out = run_dir
    cfg = load_config(out / "config.yaml")
    assert cfg.camera == sim.scenario.camera and cfg.robot == sim.scenario.robot
    assert cv2.imread(str(out / "map.png")).shape == (300, 500, 3)


def test_chen2023_is_grass_then_about_20_s_of_gravel_then_grass():
    sim = simulate(get_scenario("chen2023"), seed=0)
    terrain, t = sim.motion.terrain, sim.motion.t
    change = np.flatnonzero(terrain[1:] != terrain[:-1]) + 1
    assert [str(terrain[0])] + [str(terrain[i]) for i in change] == ["grass", "gravel", "grass"]
    assert 17.0 <= t[change[1]] - t[change[0]] <= 23.0
    assert t[change[0]] > 10.0 and t[-1] - t[change[1]] > 10.0


def test_mixed_scenario_drives_over_every_terrain():
    sc = dataclasses.replace(get_scenario("mixed"), duration=60.0)
    assert set(simulate(sc, seed=0).motion.terrain) == {"grass", "gravel", "brick"}


def _bilinear(image: np.ndarray, u: float, v: float) -> np.ndarray:
    u0, v0 = int(np.floor(u)), int(np.floor(v))
    a, b = u - u0, v - v0
    patch = image[v0 : v0 + 2, u0 : u0 + 2].astype(float)
    return (
        (1 - a) * (1 - b) * patch[0, 0]
        + a * (1 - b) * patch[0, 1]
        + (1 - a) * b * patch[1, 0]
        + a * b * patch[1, 1]
    )


@pytest.mark.parametrize("pose", [(6.0, 0.3, 0.0), (9.5, -1.0, 2.2)])
def test_rendered_pixels_show_the_map_at_their_backprojected_ground_point(pose):
    ground = build_map(small_scenario().map, np.random.default_rng(0))
    renderer = Renderer(ground, GroundCamera(SMALL_CAMERA), Lighting(amplitude=0.0, noise=0.0))
    frame = renderer.render(pose)
    pixels = np.array([[80.0, 60.0], [10.0, 110.0], [150.0, 5.0], [40.0, 30.0]])
    world = renderer.ground_points(pixels, pose)
    for (u, v), point in zip(pixels.astype(int), world, strict=True):
        mu, mv = ground.world_to_pixel(point)
        np.testing.assert_allclose(frame[v, u], _bilinear(ground.image, mu, mv), atol=1.5)


def test_a_coloured_square_appears_where_the_camera_model_projects_it():
    image = np.zeros((100, 100, 3), np.uint8)
    image[40:60, 70:90] = (255, 0, 0)  # map pixels u 70..89, v 40..59
    ground = GroundMap(image, np.zeros((100, 100), np.uint8), ["grass"], (0.0, 1.0, 0.0, 1.0), 0.01)
    camera = GroundCamera(
        CameraConfig(
            width=64,
            height=48,
            fx=40.0,
            fy=40.0,
            cx=31.5,
            cy=23.5,
            mount_x=0.0,
            mount_height=1.0,
            mount_pitch=np.pi / 2,
        )
    )
    renderer = Renderer(ground, camera, Lighting(amplitude=0.0, noise=0.0))
    pose = (0.2, 0.3, 0.0)
    centre = np.array([0.8, 0.5])  # world centre of the red square
    u, v = camera.project(centre - pose[:2])
    frame = renderer.render(pose)
    assert frame[round(v), round(u)].tolist() == [255, 0, 0]
    assert frame[0, 0].tolist() != [255, 0, 0]


def test_config_robot_scales_the_icrs_and_config_camera_is_used():
    sim = simulate(
        small_scenario(duration=0.5),
        seed=0,
        robot=RobotConfig(track_width=1.0),
        camera=dataclasses.replace(SMALL_CAMERA, width=64, height=48),
    )
    grass = TERRAIN_TABLE["grass"]
    np.testing.assert_allclose(
        sim.motion.params[0], [2 * grass.y_l, 2 * grass.y_r, 2 * grass.x_icr, grass.alpha]
    )
    assert sim.renderer.render(sim.motion.pose[0], 0.0, np.random.default_rng(0)).shape == (
        48,
        64,
        3,
    )


def test_terrain_lookup_and_leaving_the_map():
    ground = build_map(small_scenario().map, np.random.default_rng(0))
    assert ground.terrain_at([[5.0, 0.0], [9.0, 0.0], [12.0, 2.0], [20.0, 0.0]]).tolist() == [
        "grass",
        "gravel",
        "brick",
        "",
    ]
    with pytest.raises(ValueError, match="leaves the scenario.s map"):
        simulate(small_scenario(duration=30.0), seed=0)
