"""Round trip: the shipped simulated run written as a bag, imported, run: the CSV run's trajectory.

``sample_images/chen2023`` is a run of ``terrain-odom simulate`` (wheels at
50 Hz, poses at 10 Hz, 96 JPEG frames, its camera). Written as a recording
(:func:`~terrain_odom.io.bag.writer.log_records`: JointState, PoseStamped,
CompressedImage, CameraInfo, ``/tf_static``) in each bag format and
imported, it gives back the same log, frames and camera, so ``run`` gives
the same trajectory.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from terrain_odom.app.bag_import import import_bag
from terrain_odom.app.run import RunOptions, run
from terrain_odom.config import load_config
from terrain_odom.io.bag.contents import read_bag_log
from terrain_odom.io.bag.options import ImportOptions
from terrain_odom.io.bag.writer import log_records, write_bag
from terrain_odom.io.frames import read_frames
from terrain_odom.io.trajectory import read_trajectory_csv
from terrain_odom.io.wheel_log import read_wheel_log, write_wheel_log

OPTIONS = ImportOptions(
    "/joint_states",
    pose_topic="/pose",
    image_topic="/camera/image/compressed",
    wheel_radius=0.1,
    track_width=0.5,
    base_frame="base_footprint",
)


@pytest.fixture(scope="module")
def sample_bag(sample_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    cfg = load_config(sample_dir / "config.yaml")
    log = read_wheel_log(sample_dir / "log.csv")
    records = log_records(log, 0.1, frames=read_frames(sample_dir), camera=cfg.camera)
    return write_bag(tmp_path_factory.mktemp("bag") / "sample.bag", "ros1", records)


def test_the_imported_log_frames_and_camera_are_the_simulated_ones(
    sample_bag: Path, sample_dir: Path, tmp_path: Path
) -> None:
    result = import_bag(sample_bag, tmp_path, OPTIONS, progress=False)
    original, imported = read_wheel_log(sample_dir / "log.csv"), read_wheel_log(result.log_csv)
    np.testing.assert_allclose(imported.t, original.t, atol=5e-7)
    np.testing.assert_allclose(imported.v_l, original.v_l, atol=1e-9)
    np.testing.assert_allclose(imported.v_r, original.v_r, atol=1e-9)
    np.testing.assert_allclose(imported.pose, original.pose, atol=1e-9)
    frames, shipped = read_frames(tmp_path), read_frames(sample_dir)
    np.testing.assert_allclose(frames.t, shipped.t, atol=5e-7)
    assert [f.read_bytes() for f in frames.files] == [f.read_bytes() for f in shipped.files]
    camera, truth = (
        load_config(result.config_yaml).camera,
        load_config(sample_dir / "config.yaml").camera,
    )
    for key in (
        "width",
        "height",
        "fx",
        "fy",
        "cx",
        "cy",
        "mount_x",
        "mount_y",
        "mount_height",
        "mount_pitch",
        "mount_yaw",
    ):
        assert getattr(camera, key) == pytest.approx(getattr(truth, key), abs=1e-9), key
    assert result.fill_keys == ()


def test_run_on_the_import_is_the_csv_run(
    sample_bag: Path, sample_dir: Path, tmp_path: Path
) -> None:
    imported = import_bag(sample_bag, tmp_path / "imp", OPTIONS, progress=False)
    cfg = load_config(sample_dir / "config.yaml")
    # the CSV run without the log's terrain column (a bag has none): the camera drives the resets
    log = read_wheel_log(sample_dir / "log.csv")
    write_wheel_log(tmp_path / "log.csv", dataclasses.replace(log, terrain=None))
    csv_run = run(
        tmp_path / "log.csv",
        tmp_path / "csv",
        RunOptions(config=cfg, images=sample_dir, progress=False),
    )
    bag_run = run(
        imported.log_csv,
        tmp_path / "bag",
        RunOptions(config=cfg, images=tmp_path / "imp", progress=False),
    )
    a, b = (read_trajectory_csv(r.trajectory_csv) for r in (csv_run, bag_run))
    assert (
        a["t"].size == 2400
        and csv_run.report.counts.terrain_changes == bag_run.report.counts.terrain_changes == 2
    )
    for column in ("t", "x", "y", "yaw", "y_l", "y_r", "x_icr"):
        np.testing.assert_allclose(b[column], a[column], atol=1e-6, err_msg=column)
    np.testing.assert_array_equal(b["terrain"], a["terrain"])


@pytest.mark.parametrize("kind", ["sqlite3", "mcap"])
def test_direct_use_reads_every_bag_format_alike(
    sample_dir: Path, tmp_path: Path, kind: str
) -> None:
    log = read_wheel_log(sample_dir / "log.csv")
    bag = write_bag(tmp_path / kind, kind, log_records(log, 0.1))
    direct = read_bag_log(bag, dataclasses.replace(OPTIONS, image_topic=None), progress=False)
    np.testing.assert_allclose(direct.v_l, log.v_l, atol=1e-12)
    np.testing.assert_allclose(direct.pose, log.pose, atol=1e-12)
    assert direct.n_runs == 1
