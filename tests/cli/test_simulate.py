"""Tests of ``terrain-odom simulate``."""

from __future__ import annotations

import csv
import dataclasses
import json
import math

import cv2
import numpy as np
import pytest
import yaml

from terrain_odom.cli.main import main
from terrain_odom.io import read_wheel_log


def test_simulate_writes_a_run_and_prints_where(tmp_path, capsys):
    out = tmp_path / "run"
    code = main(["simulate", "--out", str(out), "--seed", "3", "--duration", "1", "--no-patches"])
    assert code == 0
    printed = capsys.readouterr().out
    assert str(out / "log.csv") in printed and str(out / "frames.csv") in printed
    log = read_wheel_log(out / "log.csv")
    assert log.t.size == 50 and set(log.terrain) == {"grass"}
    with (out / "frames.csv").open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == 10 and all((out / r["file"]).is_file() for r in rows)
    meta = json.loads((out / "simulation.json").read_text())
    assert meta["scenario"] == "chen2023" and meta["seed"] == 3
    assert not (out / "patches").exists()


def test_simulate_takes_camera_and_robot_from_the_config(tmp_path):
    config = tmp_path / "c.yaml"
    config.write_text(
        "robot: {track_width: 1.0}\ncamera: {width: 64, height: 48, cx: 31.5, cy: 23.5}\n"
    )
    out = tmp_path / "run"
    args = [
        "simulate",
        "--out",
        str(out),
        "--duration",
        "0.2",
        "--no-patches",
        "--config",
        str(config),
    ]
    assert main(args) == 0
    assert cv2.imread(str(out / "frames" / "000000.png")).shape == (48, 64, 3)
    meta = json.loads((out / "simulation.json").read_text())
    assert meta["terrains"]["grass"]["y_l"] == 0.84


def test_unknown_scenario_is_a_one_line_error(tmp_path, capsys):
    code = main(["simulate", "--out", str(tmp_path / "x"), "--scenario", "moon"])
    assert code == 2
    err = capsys.readouterr().err
    assert "unknown scenario 'moon'" in err and "chen2023" in err


def test_simulate_rates_from_the_command_line(tmp_path):
    out = tmp_path / "run"
    args = ["simulate", "--out", str(out), "--duration", "1", "--no-patches"]
    assert main([*args, "--pose-rate", "5", "--frame-rate", "2"]) == 0
    log = read_wheel_log(out / "log.csv")
    assert (~np.isnan(log.pose[:, 0])).sum() == 5
    assert len((out / "frames.csv").read_text().splitlines()) == 1 + 2


def test_pose_noise_from_the_command_line(tmp_path):
    """The measured poses scatter about the true ones by the noise asked for."""
    out = tmp_path / "run"
    args = ["simulate", "--out", str(out), "--duration", "60", "--no-frames", "--no-patches"]
    assert main([*args, "--pose-rate", "50", "--pose-noise", "0.05", "0.002"]) == 0
    log = read_wheel_log(out / "log.csv")
    with (out / "groundtruth.csv").open(newline="") as handle:
        truth = np.array([[float(r[k]) for k in ("x", "y", "yaw")] for r in csv.DictReader(handle)])
    error = log.pose - truth
    assert np.std(error[:, :2]) == pytest.approx(0.05, rel=0.05)
    assert np.std(error[:, 2]) == pytest.approx(0.002, rel=0.05)
    meta = json.loads((out / "simulation.json").read_text())
    assert meta["noise"]["pose_xy_m"] == 0.05 and meta["noise"]["pose_yaw_rad"] == 0.002


@pytest.mark.parametrize("noise", [["-0.01", "0.01"], ["0.01", "inf"], ["nan", "0.01"]])
def test_bad_pose_noise_is_a_one_line_error(tmp_path, capsys, noise):
    assert main(["simulate", "--out", str(tmp_path / "x"), "--pose-noise", *noise]) == 2
    assert "--pose-noise must be two finite values >= 0" in capsys.readouterr().err


def test_a_rate_the_wheel_rate_is_not_a_multiple_of_is_an_error(tmp_path, capsys):
    args = ["simulate", "--out", str(tmp_path / "x"), "--frame-rate", "7"]
    assert main(args) == 2
    assert "frame_rate" in capsys.readouterr().err


def test_jpg_frame_format_writes_jpeg_frames_and_map(tmp_path):
    out = tmp_path / "run"
    args = ["simulate", "--out", str(out), "--duration", "1", "--frame-rate", "2"]
    assert main([*args, "--no-patches", "--frame-format", "jpg"]) == 0
    with (out / "frames.csv").open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert [r["file"] for r in rows] == ["frames/000000.jpg", "frames/000001.jpg"]
    for row in rows:
        data = (out / row["file"]).read_bytes()
        assert data[:3] == b"\xff\xd8\xff"  # JPEG start-of-image marker
        assert cv2.imread(str(out / row["file"])).shape == (240, 320, 3)
    assert not list((out / "frames").glob("*.png"))
    assert (out / "map.jpg").is_file() and not (out / "map.png").exists()
    meta = json.loads((out / "simulation.json").read_text())
    assert meta["map"]["preview"]["file"] == "map.jpg"


def test_jpg_frames_are_smaller_and_close_to_the_png_ones(tmp_path):
    args = ["simulate", "--duration", "0.2", "--frame-rate", "5", "--no-patches"]
    assert main([*args, "--out", str(tmp_path / "png")]) == 0
    assert main([*args, "--out", str(tmp_path / "jpg"), "--frame-format", "jpg"]) == 0
    png = tmp_path / "png" / "frames" / "000000.png"
    jpg = tmp_path / "jpg" / "frames" / "000000.jpg"
    assert jpg.stat().st_size < png.stat().st_size / 3
    a = cv2.imread(str(png)).astype(float)
    b = cv2.imread(str(jpg)).astype(float)
    assert np.abs(a - b).mean() < 4.0


def test_unknown_frame_format_is_refused(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["simulate", "--out", str(tmp_path / "x"), "--frame-format", "gif"])
    assert exc.value.code == 2
    assert "--frame-format" in capsys.readouterr().err


def test_write_simulation_checks_the_frame_format(tmp_path):
    from terrain_odom.app.simulate import write_simulation
    from terrain_odom.sim import get_scenario, simulate

    sim = simulate(dataclasses.replace(get_scenario("chen2023"), duration=0.1), seed=0)
    with pytest.raises(ValueError, match="frame_format"):
        write_simulation(sim, tmp_path / "x", frame_format="bmp")


def test_mounting_options_move_the_fixes_and_the_headings(tmp_path):
    out = tmp_path / "run"
    args = ["simulate", "--out", str(out), "--duration", "2", "--no-frames", "--no-patches"]
    assert main([*args, "--pose-noise", "0", "0", "--antenna", "0.5", "-0.2"]) == 0
    with (out / "groundtruth.csv").open(newline="") as handle:
        truth = np.array([[float(r[k]) for k in ("x", "y", "yaw")] for r in csv.DictReader(handle)])
    pose = read_wheel_log(out / "log.csv").pose
    rows = np.isfinite(pose[:, 0])
    c, s = np.cos(truth[rows, 2]), np.sin(truth[rows, 2])
    antenna = truth[rows, :2] + np.column_stack([0.5 * c + 0.2 * s, 0.5 * s - 0.2 * c])
    np.testing.assert_allclose(pose[rows, :2], antenna, atol=1e-6)
    assert main([*args, "--pose-noise", "0", "0", "--heading-offset", "-3"]) == 0
    pose = read_wheel_log(out / "log.csv").pose
    turn = np.angle(np.exp(1j * (pose[rows, 2] - truth[rows, 2])))
    np.testing.assert_allclose(turn, -3.0, atol=1e-6)
    sensor = yaml.safe_load((out / "config.yaml").read_text())["pose_sensor"]
    assert sensor == {"antenna_x": 0.0, "antenna_y": 0.0, "heading_offset": -3.0}
    assert json.loads((out / "simulation.json").read_text())["pose_sensor"] == sensor


@pytest.mark.parametrize(
    ("option", "values"), [("--antenna", ["11", "0"]), ("--heading-offset", ["10"])]
)
def test_bad_mounting_is_a_one_line_error(tmp_path, capsys, option, values):
    assert main(["simulate", "--out", str(tmp_path / "x"), option, *values]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and option in err


@pytest.fixture(scope="module")
def mounted(tmp_path_factory, recording):
    """Simulate a minute of the mixed tour: GPS 0.5 m ahead (0.3 m, 2.5 Hz), IMU turned 10 deg.

    Return the recording's folder and its configuration without ``pose_sensor`` (beside it).
    """
    out = recording(
        60.0,
        seed=0,
        scenario="mixed",
        write=True,
        pose_rate=2.5,
        sigma_xy=0.3,
        sigma_yaw=0.01,
        antenna=(0.5, 0.0),
        heading_offset=math.radians(10),
    ).folder
    config = yaml.safe_load((out / "config.yaml").read_text())
    config.pop("pose_sensor")
    without = tmp_path_factory.mktemp("mounted") / "without.yaml"
    without.write_text(yaml.safe_dump(config))
    return out, without


@pytest.mark.parametrize(("estimator", "error_m"), [("icr-ekf", 0.3), ("slip-ekf", 0.45)])
def test_run_with_the_simulated_mounting_converges_without_it_stops(
    mounted, tmp_path, capsys, estimator, error_m
):
    mounted, without_yaml = mounted
    args = ["run", "--wheels", str(mounted / "log.csv"), "--estimator", estimator]
    without = [*args, "--out", str(tmp_path / "without"), "--config", str(without_yaml)]
    assert main(without) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "pose_sensor.heading_offset" in err and "+8.0 deg" in err
    out = tmp_path / "with"
    assert main([*args, "--out", str(out), "--config", str(mounted / "config.yaml")]) == 0
    truth, run = _columns(mounted / "groundtruth.csv"), _columns(out / "trajectory.csv")
    position = np.hypot(run[:, 0] - truth[:, 0], run[:, 1] - truth[:, 1])
    assert position.mean() < error_m  # 0.24 m (ICR EKF), 0.40 m (slip EKF); 0.57, 0.64 without
    if estimator == "icr-ekf":  # the lever arm is not learned as an x_icr (-0.28 m without)
        assert abs(np.median(run[len(run) // 2 :, 2] - truth[len(run) // 2 :, 2])) < 0.05


def _columns(path, names=("x", "y", "x_icr")):
    with path.open(newline="") as handle:
        return np.array([[float(r[k]) for k in names] for r in csv.DictReader(handle)])
