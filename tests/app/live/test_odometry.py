"""The live layer under the ROS node, without ROS: order, late and bad messages, frames off the path.

Messages are ``rosbags``' objects (the real Jackal bag's, and the shipped
simulated run's as :func:`~terrain_odom.io.bag.writer.log_records` builds
them), fed as a node would, one by one.
"""

from __future__ import annotations

import dataclasses
import json
import math
import threading
import time
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from terrain_odom.app.live.build import build_live
from terrain_odom.app.live.odometry import LiveOdometry
from terrain_odom.app.live.options import LiveOptions, LiveTopics
from terrain_odom.app.live.output import LiveOutput
from terrain_odom.app.run import RunOptions, run
from terrain_odom.config import Config, load_config
from terrain_odom.estimation.odometry import run_odometry
from terrain_odom.estimation.online import OnlineOdometry
from terrain_odom.io.bag.contents import read_bag_log
from terrain_odom.io.bag.messages import IMU, ODOMETRY
from terrain_odom.io.bag.options import ImportOptions
from terrain_odom.io.bag.reader import open_bag, stream_messages
from terrain_odom.io.bag.writer import MessageFactory, log_records
from terrain_odom.io.frames import read_frames
from terrain_odom.io.wheel_log import read_wheel_log
from terrain_odom.records import Sighting
from tests.conftest import SHARED_DATA

ODOM, IMU_TOPIC = "/jackal_velocity_controller/odom", "/imu/data"
TRACK = 0.563
ROLE = {ODOM: "wheels", IMU_TOPIC: "heading"}


@pytest.fixture(scope="module")
def jackal_messages() -> list[Any]:
    bag = SHARED_DATA / "bags" / "jackal_odom_imu.bag"
    if not bag.is_file():
        pytest.skip(f"real data not present: {bag} (../shared beside the repository)")
    with open_bag(bag) as reader:
        conns = [c for c in reader.connections if c.topic in ROLE]
        return [m for m in stream_messages(reader, bag, conns, False) if m.receive_ns < 67e9]


def _jackal_config() -> Config:
    cfg = load_config(None)
    return dataclasses.replace(cfg, robot=dataclasses.replace(cfg.robot, track_width=TRACK))


def _feed(live: LiveOdometry, messages: list[Any]) -> None:
    for m in messages:
        live.message(ROLE[m.topic], m.msgtype, m.msg, m.receive_ns)
    live.close()


def _live(
    outputs: list[LiveOutput], warnings: list[str] | None = None, **options: Any
) -> LiveOdometry:
    return LiveOdometry(
        OnlineOdometry(_jackal_config()),
        LiveTopics(ODOM, heading=IMU_TOPIC),
        LiveOptions(**options),
        on_output=outputs.append,
        on_warning=(warnings if warnings is not None else []).append,
    )


def test_the_real_bag_fed_live_gives_runs_estimates(jackal_messages: list[Any]) -> None:
    # the reference: the log import would write of these 20 s, run row by row (run's loop)
    bag = SHARED_DATA / "bags" / "jackal_odom_imu.bag"
    log = read_bag_log(bag, ImportOptions(ODOM, heading_topic=IMU_TOPIC, track_width=TRACK))
    result = run_odometry(log, OnlineOdometry(_jackal_config()))
    outputs: list[LiveOutput] = []
    live = _live(outputs)
    _feed(live, jackal_messages)
    t = np.array([o.t for o in outputs])
    rows = np.searchsorted(log.t, t)
    assert rows.size > 1900 and np.array_equal(log.t[rows], t)  # every live row is a log row
    assert rows.tolist() == list(range(rows.size))  # ... and in the same order, none missing
    states = np.array([o.state for o in outputs])
    # the same calls in the same order: the same numbers, bit for bit
    np.testing.assert_array_equal(states, result.states[rows])
    np.testing.assert_array_equal(np.array([o.std for o in outputs]), result.stds[rows])
    assert live.dropped == {"heading: before the first wheel message": 1}
    assert live.counts["rows"] == rows.size


def test_messages_shuffled_within_the_delay_give_the_same_estimates(
    jackal_messages: list[Any],
) -> None:
    in_order: list[LiveOutput] = []
    _feed(_live(in_order), jackal_messages[:600])
    rng = np.random.default_rng(3)
    shuffled = list(jackal_messages[:600])
    for start in range(0, 600, 4):  # 4 messages span < 40 ms of stamps: within the 0.1-s delay
        block = shuffled[start : start + 4]
        shuffled[start : start + 4] = [block[i] for i in rng.permutation(len(block))]
    assert shuffled != jackal_messages[:600]
    out: list[LiveOutput] = []
    _feed(_live(out), shuffled)
    np.testing.assert_array_equal([o.state for o in out], [o.state for o in in_order])


def test_late_nan_and_wrong_type_messages_are_dropped_counted_and_reported_once(
    jackal_messages: list[Any],
) -> None:
    out: list[LiveOutput] = []
    warnings: list[str] = []
    live = _live(out, warnings)
    messages = jackal_messages[:400]
    late = [m for m in messages[340:380] if m.topic == ODOM][:3]  # 0.2-0.6 s old: late
    for m in messages:
        live.message(ROLE[m.topic], m.msgtype, m.msg, m.receive_ns)
    for m in late:  # stamped before rows already processed
        live.message("wheels", m.msgtype, m.msg, m.receive_ns)
    nan_msg = MessageFactory().odometry(int(messages[-1].receive_ns) + 10**6)
    nan_msg.twist.twist.linear.x = math.nan
    live.message("wheels", ODOMETRY, nan_msg)
    live.message("wheels", ODOMETRY, nan_msg)
    live.message("wheels", IMU, messages[1].msg)  # an Imu on the wheels topic
    live.message("wheels", "std_msgs/String", SimpleNamespace(data="x"))
    n_before = len(out)
    for m in jackal_messages[400:500]:  # alive: later messages still give estimates
        live.message(ROLE[m.topic], m.msgtype, m.msg, m.receive_ns)
    live.close()
    assert len(out) > n_before + 90
    assert live.dropped["wheels: wheel speed not finite (NaN or inf)"] == 2
    assert live.dropped["wheels: a message of type sensor_msgs/Imu (expected "
                        "sensor_msgs/JointState, nav_msgs/Odometry, geometry_msgs/TwistStamped)"] == 1  # fmt: skip
    assert sum(n for r, n in live.dropped.items() if "std_msgs/String" in r) == 1
    late_key = "wheels: late (stamped before a row already processed)"
    assert live.dropped[late_key] == 3 and "time jumped back (restarts)" not in live.dropped
    assert len(warnings) == len(set(warnings)) == len(live.dropped)  # each reason once
    assert all(np.isfinite(o.state).all() for o in out)


def test_a_jump_back_in_time_starts_a_new_segment(jackal_messages: list[Any]) -> None:
    out: list[LiveOutput] = []
    warnings: list[str] = []
    live = _live(out, warnings)
    first = jackal_messages[:300]
    for m in first + first:  # rosbag play --loop: time jumps back ~3 s
        live.message(ROLE[m.topic], m.msgtype, m.msg, m.receive_ns)
    live.close()
    assert live.dropped["time jumped back (restarts)"] == 1
    assert any("jumped back" in w for w in warnings)
    t = np.array([o.t for o in out])
    jump = int(np.argmax(np.diff(t) < 0)) + 1
    assert t[jump] == pytest.approx(t[0], abs=0.05)  # the loop's rows again, from its start
    assert jump > 250 and len(out) - jump > 250


def test_before_the_first_wheel_and_in_a_gap_poses_are_dropped() -> None:
    m = MessageFactory()
    out: list[LiveOutput] = []
    live = LiveOdometry(
        OnlineOdometry(Config()),
        LiveTopics("/w", pose="/p"),
        LiveOptions(delay=0.0),
        on_output=out.append,
    )
    s = 10**9
    live.message("pose", "geometry_msgs/PoseStamped", m.pose_stamped(s, 0.0, 0.0, 0.0))
    live.message("wheels", ODOMETRY, m.odometry(2 * s, twist=(1.0, 0.0)))
    live.message("pose", "geometry_msgs/PoseStamped", m.pose_stamped(3 * s, 0.0, 0.0, 0.0))
    live.message("wheels", ODOMETRY, m.odometry(4 * s, twist=(1.0, 0.0)))
    live.close()
    assert live.dropped == {
        "pose: before the first wheel message": 1,
        "pose: in a gap of the wheel messages (longer than max_gap)": 1,
    }
    assert [o.t for o in out] == [0.0, 2.0]  # the second wheel message: a new segment


def test_poll_releases_the_buffer_of_a_paused_stream(jackal_messages: list[Any]) -> None:
    now = [0.0]
    out: list[LiveOutput] = []
    live = LiveOdometry(
        OnlineOdometry(_jackal_config()),
        LiveTopics(ODOM, heading=IMU_TOPIC),
        LiveOptions(delay=0.1, idle=0.25),
        on_output=out.append,
        clock=lambda: now[0],
    )
    for m in jackal_messages[:50]:
        live.message(ROLE[m.topic], m.msgtype, m.msg, m.receive_ns)
    held = 50 - 1 - len(out)  # the first heading is dropped; the rest within 0.1 s is held
    assert held > 5
    now[0] = 0.2
    live.poll()
    assert 50 - 1 - len(out) == held  # not idle yet
    now[0] = 0.3
    live.poll()
    assert len(out) == 49


# ------------------------------------------------------------ frames
def _sample_records(sample_dir: Path) -> list[Any]:
    cfg = load_config(sample_dir / "config.yaml")
    log = read_wheel_log(sample_dir / "log.csv")
    return log_records(log, 0.1, frames=read_frames(sample_dir), camera=cfg.camera)


ROLES_SIM = {"/joint_states": "wheels", "/pose": "pose", "/camera/image/compressed": "images"}


def _changes_live(sample_dir: Path, frames: str) -> tuple[list, LiveOdometry]:
    out: list[LiveOutput] = []
    live = build_live(
        sample_dir / "config.yaml",
        LiveTopics("/joint_states", pose="/pose", images="/camera/image/compressed"),
        LiveOptions(frames=frames),
        on_output=out.append,
    )
    for topic, kind, ns, msg in _sample_records(sample_dir):
        if topic in ROLES_SIM:
            live.message(ROLES_SIM[topic], kind, msg, ns)
    live.close()
    return [c for o in out for c in o.changes], live


@pytest.fixture(scope="module")
def run_changes(sample_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> list[dict]:
    out = tmp_path_factory.mktemp("run")
    run(
        sample_dir / "log.csv",
        out,
        RunOptions(images=sample_dir, overwrite=True, plots=False, progress=False),
    )
    return json.loads((out / "report.json").read_text())["terrain_changes"]


def test_frames_in_sync_give_runs_terrain_changes(
    sample_dir: Path, run_changes: list[dict]
) -> None:
    """Fed faster than real time: each classification waited for (``frames="sync"``)."""
    changes, live = _changes_live(sample_dir, "sync")
    assert live.counts["frames_classified"] == 96
    assert [(c.t, c.previous, c.label) for c in changes] == [
        (c["t"], c["previous"], c["label"]) for c in run_changes
    ]
    assert len(changes) == 2


def test_a_slow_frame_does_not_stall_the_wheels_and_lands_where_it_looked(
    sample_dir: Path, run_changes: list[dict]
) -> None:
    """Frames taking 40 ms more (2 wheel periods), fed at 4 times real time, no reorder delay.

    Wheel messages go on while a frame is classified, and the change lands
    where ``run`` puts it (the sighting placed where the frame looked).
    """
    stalls: list[float] = []
    records = [r for r in _sample_records(sample_dir) if r[0] in ROLES_SIM]
    records = [r for r in records if r[2] < records[0][2] + 23 * 10**9]  # the first change
    out: list[LiveOutput] = []
    live = build_live(
        sample_dir / "config.yaml",
        LiveTopics("/joint_states", pose="/pose", images="/camera/image/compressed"),
        LiveOptions(delay=0.0),
        on_output=out.append,
    )
    worker = live._worker
    assert worker is not None
    classify = worker.classifier.classify
    busy = threading.Event()

    def slow(*args: Any, **kwargs: Any) -> Any:
        busy.set()
        time.sleep(0.04)
        result = classify(*args, **kwargs)
        busy.clear()
        return result

    worker.classifier = SimpleNamespace(classify=slow)  # type: ignore[assignment]
    for topic, kind, ns, msg in records:
        started = time.perf_counter()
        live.message(ROLES_SIM[topic], kind, msg, ns)
        if topic == "/joint_states":
            if busy.is_set():
                stalls.append(time.perf_counter() - started)
            time.sleep(0.005)  # 50-Hz wheel messages at 4 times real time
    live.close()
    assert len(stalls) > 100  # wheel messages were processed while a frame was classified
    assert np.median(stalls) < 0.005  # ... without waiting for it
    changes = [c for o in out for c in o.changes]
    first = run_changes[0]
    assert [(c.t, c.previous, c.label) for c in changes] == [
        (first["t"], first["previous"], first["label"])
    ]


def test_the_odometer_the_late_sightings_are_placed_by() -> None:
    """``OnlineOdometry.odometer``: 0 until a sighting ahead, then the distance driven.

    The live layer places a sighting fed late at ``ahead`` less the
    odometer's advance since its frame; a change 2 m ahead lands 2 m on.
    """
    cfg = Config()
    odo = OnlineOdometry(cfg)
    odo.wheels(0.0, 1.0, 1.0)
    odo.sighting(0.0, Sighting("grass", 0.0))
    odo.sighting(0.0, Sighting("grass", 0.0))
    odo.sighting(0.0, Sighting("gravel", 2.0))
    odo.sighting(0.0, Sighting("gravel", 2.0))  # confirmed, 2 m ahead: the odometer runs
    assert odo.odometer == 0.0
    for k in range(1, 11):
        odo.wheels(0.1 * k, 1.0, 1.0)
    assert odo.odometer == pytest.approx(1.0)
    assert odo.current_terrain == "grass"
    for k in range(11, 21):
        odo.wheels(0.1 * k, 1.0, 1.0)
    assert odo.current_terrain == "gravel" and odo.changes[-1].t == pytest.approx(2.0)


def test_frames_faster_than_the_classifier_are_skipped_not_queued(sample_dir: Path) -> None:
    """A classifier 10x slower than the frames: at most a few wait, the rest are counted."""
    records = [r for r in _sample_records(sample_dir) if r[0] in ROLES_SIM][:600]
    live = build_live(
        sample_dir / "config.yaml",
        LiveTopics("/joint_states", pose="/pose", images="/camera/image/compressed"),
        LiveOptions(delay=0.0),
    )
    worker = live._worker
    assert worker is not None
    classify = worker.classifier.classify
    waiting = []

    def slow(*args: Any, **kwargs: Any) -> Any:
        time.sleep(0.05)
        return classify(*args, **kwargs)

    worker.classifier = SimpleNamespace(classify=slow)  # type: ignore[assignment]
    for topic, kind, ns, msg in records:
        live.message(ROLES_SIM[topic], kind, msg, ns)
        waiting.append(worker.pending)
    live.close()
    skipped = live.dropped["images: the classifier is behind (frames skipped to keep up)"]
    assert max(waiting) <= 3 and skipped > 0
    assert live.counts["frames_classified"] + skipped == live.counts["images"]


def test_an_unknown_role_is_a_clear_error_not_a_dropped_message() -> None:
    outputs: list[LiveOutput] = []
    live = _live(outputs)
    with pytest.raises(ValueError, match="unknown role 'odom': expected one of wheels"):
        live.message("odom", ODOMETRY, object())
    assert live.dropped == {}  # a caller's mistake: not counted as a bad message
