"""``terrain-odom-ros`` against a real ROS master: bags played, bad input published, shutdown.

Ordering: the node releases messages in stamp order after a delay
(docs/ros.md); with ``--delay`` longer than any transport lag, a played bag
is a deterministic feed, and the node's estimate at every row is ``run``'s
on the bag imported.
"""

from __future__ import annotations

import json
import re
import signal
import subprocess
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from terrain_odom.app.bag_import import import_bag
from terrain_odom.app.run import RunOptions, run
from terrain_odom.config import load_config
from terrain_odom.io.bag.messages import stamp_ns, yaw_from_quaternion
from terrain_odom.io.bag.options import ImportOptions
from terrain_odom.io.bag.writer import log_records, write_bag
from terrain_odom.io.frames import read_frames
from terrain_odom.io.trajectory import read_trajectory_csv
from terrain_odom.io.wheel_log import read_wheel_log
from tests.conftest import SHARED_DATA
from tests.ros.conftest import HERE, Ros, read_bag

ODOM, IMU = "/jackal_velocity_controller/odom", "/imu/data"
OUTPUTS = ["/odometry", "/icr", "/terrain", "/terrain_changes", "/terrain_odom/status"]


def _play(ros: Ros, bag: Path, *args: str) -> None:
    ros.tool("rosbag", "play", "--clock", "-q", str(bag), *args, timeout=300.0)


def _quiet(ros: Ros, timeout: float = 60.0) -> None:
    """Wait until the node's latched status (counts, drops; published every second) holds still.

    A fixed pause lost the last camera frame on a loaded machine: the frame
    worker finished it after the last status the recorder heard.
    """
    last = None
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        time.sleep(1.5)
        now = ros.tool("rostopic", "echo", "-n", "1", "/terrain_odom/status")
        if now and now == last:
            return
        last = now
    raise AssertionError(f"the node's status still changed after {timeout:g} s: {last}")


def _finish(ros: Ros, node: subprocess.Popen[bytes], recorder: subprocess.Popen[bytes]) -> None:
    """Let the last messages through, then stop the recorder and the node (SIGINT: exit 0)."""
    _quiet(ros)
    assert ros.stop(node, signal.SIGINT) == 0, ros.log("node.log")
    ros.stop(recorder, signal.SIGINT)
    assert "terrain-odom-ros: " in ros.log("node.log")  # the summary line at shutdown


def _status(recorded: dict[str, list[tuple[int, Any]]]) -> dict[str, Any]:
    return json.loads(recorded["/terrain_odom/status"][-1][1].data)


@pytest.fixture(scope="module")
def jackal(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, dict[str, np.ndarray]]:
    """Return the real bag, its import's configuration, and ``terrain-odom run`` on the import."""
    bag = SHARED_DATA / "bags" / "jackal_odom_imu.bag"
    if not bag.is_file():
        pytest.skip(f"real data not present: {bag} (../shared beside the repository)")
    out = tmp_path_factory.mktemp("jackal")
    imported = import_bag(
        bag, out / "imp", ImportOptions(ODOM, heading_topic=IMU, track_width=0.563)
    )
    run(
        imported.log_csv,
        out / "run",
        RunOptions(config_path=imported.config_yaml, plots=False, progress=False),
    )
    return bag, imported.config_yaml, read_trajectory_csv(out / "run" / "trajectory.csv")


def test_the_real_bag_played_into_the_node_gives_runs_estimates(ros: Ros, jackal: Any) -> None:
    bag, config, trajectory = jackal
    ros.tool("rosparam", "set", "/use_sim_time", "true")
    node = ros.node(
        [
            "--config",
            str(config),
            "--wheels-topic",
            ODOM,
            "--heading-topic",
            IMU,
            "--delay",
            "0.5",
            "--idle",
            "1",
            "--publish-tf",
        ]  # fmt: skip
    )
    recorder = ros.record(ros.folder / "jackal_out.bag", [*OUTPUTS, "/tf"])
    _play(ros, bag, "-u", "12")
    _finish(ros, node, recorder)
    recorded = read_bag(ros.folder / "jackal_out.bag")
    odometry = [msg for _, msg in recorded["/odometry"]]
    t = np.array([stamp_ns(m.header.stamp) for m in odometry]) / 1e9 - 47.0  # import's origin
    rows = np.searchsorted(trajectory["t"], t - 1e-7)
    np.testing.assert_allclose(trajectory["t"][rows], t, atol=1e-6)
    assert rows.tolist() == list(range(rows.size)) and rows.size > 1100  # every row, in order
    pose = np.array(
        [[m.pose.pose.position.x, m.pose.pose.position.y,
          yaw_from_quaternion(0.0, 0.0, m.pose.pose.orientation.z, m.pose.pose.orientation.w)]
         for m in odometry]
    )  # fmt: skip
    expected = np.column_stack([trajectory[k][rows] for k in ("x", "y", "yaw")])
    np.testing.assert_allclose(pose, expected, atol=1e-6)  # the last pose too
    variances = np.array([[m.pose.covariance[0], m.pose.covariance[35]] for m in odometry])
    np.testing.assert_allclose(variances, np.column_stack([trajectory["std_x"][rows] ** 2,
                                                           trajectory["std_yaw"][rows] ** 2]),
                               rtol=1e-6, atol=1e-12)  # fmt: skip
    icr = np.array([m.data for _, m in recorded["/icr"]])
    assert icr.shape == (rows.size, 8)
    np.testing.assert_allclose(icr[:, 0], trajectory["y_l"][rows], atol=1e-6)
    np.testing.assert_allclose(icr[:, 7], trajectory["std_alpha"][rows], atol=1e-6)
    tf = [tr for _, msg in recorded["/tf"] for tr in msg.transforms]
    assert len(tf) == len(odometry)  # odom -> base_link at each row, the pose's
    assert (tf[-1].header.frame_id, tf[-1].child_frame_id) == ("odom", "base_link")
    assert tf[-1].transform.translation.x == odometry[-1].pose.pose.position.x
    status = _status(recorded)
    assert status["dropped"] == {"heading: before the first wheel message": 1}
    assert odometry[-1].child_frame_id == "base_link" and odometry[-1].header.frame_id == "odom"


@pytest.fixture(scope="module")
def camera_bag(sample_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list]:
    """Return the simulated run with its camera frames as a ROS 1 bag, and ``run``'s changes."""
    out = tmp_path_factory.mktemp("camera")
    cfg = load_config(sample_dir / "config.yaml")
    log = read_wheel_log(sample_dir / "log.csv")
    records = log_records(log, 0.1, frames=read_frames(sample_dir), camera=cfg.camera)
    bag = write_bag(out / "camera.bag", "ros1", records)
    run(
        sample_dir / "log.csv",
        out / "run",
        RunOptions(images=sample_dir, plots=False, progress=False),
    )
    return bag, json.loads((out / "run" / "report.json").read_text())["terrain_changes"]


def test_camera_frames_give_the_terrain_changes_of_run(
    ros: Ros, camera_bag: Any, sample_dir: Path
) -> None:
    bag, changes = camera_bag
    ros.tool("rosparam", "set", "/use_sim_time", "true")
    node = ros.node(
        [
            "--config",
            str(sample_dir / "config.yaml"),
            "--wheels-topic",
            "/joint_states",
            "--pose-topic",
            "/pose",
            "--image-topic",
            "/camera/image/compressed",
        ]  # fmt: skip
    )
    recorder = ros.record(ros.folder / "camera_out.bag", OUTPUTS)
    _play(ros, bag, "-r", "2")
    _finish(ros, node, recorder)
    recorded = read_bag(ros.folder / "camera_out.bag")
    told = [msg.data for _, msg in recorded["/terrain_changes"]]
    parsed = [re.match(r"t=(\S+) (\S+) -> (\S+)", text).groups() for text in told]  # type: ignore[union-attr]
    assert [(float(t), a, b) for t, a, b in parsed] == [
        (c["t"], c["previous"], c["label"]) for c in changes
    ]
    assert [msg.data for _, msg in recorded["/terrain"]] == ["grass", "gravel", "grass"]
    status = _status(recorded)
    assert status["counts"]["frames_classified"] == 96 and status["dropped"] == {}


def test_bad_input_is_counted_reported_once_and_the_node_lives_on(ros: Ros) -> None:
    ros.tool("rosparam", "set", "/use_sim_time", "false")
    node = ros.node(
        [
            "--wheels-topic",
            "/bad/wheels",
            "--heading-topic",
            "/bad/imu",
            "--track-width",
            "0.5",
            "--delay",
            "0.05",
        ]  # fmt: skip
    )
    publisher = ros.start(
        [ros.python, str(HERE / "publish_bad.py"), "/bad/wheels", "/bad/imu"], "pub.log"
    )
    assert publisher.wait(120) == 0, ros.log("pub.log")
    assert "published" in ros.log("pub.log")
    time.sleep(1.5)  # the status is published every second
    echoed = ros.tool("rostopic", "echo", "-n", "1", "/terrain_odom/status")
    status = json.loads(yaml.safe_load(echoed.split("---")[0])["data"])
    dropped = status["dropped"]
    assert dropped["wheels: wheel speed not finite (NaN or inf)"] == 5
    assert dropped["wheels: late (stamped before a row already processed)"] == 3
    assert dropped["heading: a message of type std_msgs/String (expected sensor_msgs/Imu)"] == 3
    assert dropped["time jumped back (restarts)"] == 1
    assert status["counts"]["rows"] >= 190  # both runs of 100 good messages, but the buffered
    log = ros.log("node.log")
    warned = [line for line in log.splitlines() if "[WARN]" in line]
    for reason in ("not finite (NaN or inf)", "late (stamped", "std_msgs/String", "jumped back"):
        assert sum(reason in line for line in warned) == 1, (
            reason
        )  # logged once (then counted; in the summary)
    assert "/terrain_odom" in ros.tool("rosnode", "list")  # alive
    ros.tool("rosnode", "kill", "/terrain_odom")
    assert node.wait(30) == 0, ros.log("node.log")
    summary = ros.log("node.log").rsplit("terrain-odom-ros: ", 1)[1]
    assert "5 wheels: wheel speed not finite (NaN or inf)" in summary
