"""Issue 24: bags with non-finite wheel speeds and raw images that disagree with their size."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from terrain_odom.cli.main import main
from terrain_odom.io.bag.writer import MessageFactory, write_bag
from terrain_odom.io.wheel_log import read_wheel_log

M = MessageFactory()
BASE = 1_700_000_000 * 10**9
NS = [BASE + k * 50_000_000 for k in range(41)]
NAN, INF = float("nan"), float("inf")


def _bag(tmp_path: Path, records: list) -> Path:
    folder = write_bag(tmp_path / "rec", "mcap", sorted(records, key=lambda r: r[2]))
    return next(folder.glob("*.mcap"))


def _joint_states(bad: dict[int, tuple[float, float]]) -> list:
    return [
        (
            "/joints",
            "sensor_msgs/msg/JointState",
            t,
            M.joint_state(t, ["left_wheel", "right_wheel"], bad.get(k, (5.0, 6.0))),
        )
        for k, t in enumerate(NS)
    ]


def _odometry(bad: dict[int, tuple[float, float]]) -> list:
    return [
        ("/odom", "nav_msgs/msg/Odometry", t, M.odometry(t, twist=bad.get(k, (0.5, 0.2))))
        for k, t in enumerate(NS)
    ]


@pytest.mark.parametrize(
    ("records", "topic"),
    [
        (_joint_states({3: (NAN, 6.0), 9: (5.0, INF), 20: (-INF, INF)}), "/joints"),
        (_odometry({3: (NAN, 0.2), 9: (0.5, INF), 20: (INF, -INF)}), "/odom"),
    ],
)
def test_non_finite_wheel_speeds_are_dropped_and_counted(
    records: list, topic: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Three bad messages of 41: dropped, counted in the output and import.json; the log is finite."""
    bag, out = _bag(tmp_path, records), tmp_path / "out"
    argv = ["import", str(bag), "--out", str(out), "--wheels-topic", topic]
    assert main([*argv, "--track-width", "0.4", "--wheel-radius", "0.1"]) == 0
    printed = capsys.readouterr()
    assert "RuntimeWarning" not in printed.err
    log = read_wheel_log(out / "log.csv")
    assert len(log) == 38 and np.isfinite(log.v_l).all() and np.isfinite(log.v_r).all()
    report = json.loads((out / "import.json").read_text())
    skipped = report["skipped"][f"--wheels-topic {topic}"]
    assert skipped == {"wheel speed not finite (NaN or inf)": 3}
    assert "wheel speed not finite (NaN or inf)" in printed.out
    # the imported log runs
    run = ["run", "--wheels", str(out / "log.csv"), "--out", str(tmp_path / "run")]
    assert main([*run, "--config", str(out / "config.yaml"), "--no-plots"]) == 0


@pytest.mark.parametrize(
    "change",
    [{"width": 60, "step": 180}, {"height": 40}, {"step": 2}, {"width": 0, "step": 0}],
)
def test_a_raw_image_disagreeing_with_its_size_is_one_line(
    change: dict, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    raw = np.zeros((4, 6, 3), np.uint8)
    image = dataclasses.replace(M.image(NS[5], raw), **change)
    records = [*_odometry({}), ("/cam/image_raw", "sensor_msgs/msg/Image", NS[5], image)]
    bag, out = _bag(tmp_path, records), tmp_path / "out"
    argv = ["import", str(bag), "--out", str(out), "--wheels-topic", "/odom"]
    capsys.readouterr()
    assert main([*argv, "--track-width", "0.4", "--image-topic", "/cam/image_raw"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "/cam/image_raw" in err, err
    assert "bytes of data, it holds 72" in err
    assert not (out / "log.csv").exists() and not (out / "config.yaml").exists()


def test_an_unknown_message_encoding_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """An MCAP channel whose messages are not CDR is refused, not decoded as CDR."""
    bag = _bag(tmp_path, _odometry({}))
    data = bag.read_bytes()
    assert data.count(b"\x03\x00\x00\x00cdr") == 2  # the channel record, and its summary copy
    odd = tmp_path / "json.mcap"
    odd.write_bytes(data.replace(b"\x03\x00\x00\x00cdr", b"\x03\x00\x00\x00jsn"))
    out = tmp_path / "out"
    argv = ["import", str(odd), "--out", str(out), "--wheels-topic", "/odom", "--track-width", "1"]
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "topic /odom: messages encoded as 'jsn'; terrain-odom reads ROS 1 and CDR" in err
    assert not (out / "log.csv").exists()


def _imported(
    tmp_path: Path, records: list, capsys: pytest.CaptureFixture[str], *extra: str
) -> str:
    """Import a bag of ``records`` that must fail: one line, nothing that looks complete."""
    bag, out = _bag(tmp_path, [*_odometry({}), *records]), tmp_path / "out"
    argv = ["import", str(bag), "--out", str(out), "--wheels-topic", "/odom", *extra]
    capsys.readouterr()
    assert main([*argv, "--track-width", "0.4"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Warning" not in err, err
    for name in ("log.csv", "config.yaml", "import.json", "frames.csv"):
        assert not (out / name).exists(), name
    return err


@pytest.mark.parametrize(("fx", "width"), [(0.0, 32), (-40.0, 32), (40.0, 0)])
def test_camera_info_that_makes_no_camera_is_refused_before_writing(
    fx: float, width: int, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    raw = np.zeros((24, 32, 3), np.uint8)
    records = [
        ("/cam/image_raw", "sensor_msgs/msg/Image", NS[5], M.image(NS[5], raw)),
        (
            "/cam/camera_info",
            "sensor_msgs/msg/CameraInfo",
            NS[1],
            M.camera_info(NS[1], width, 24, fx, 15.5, 11.5),
        ),
    ]
    err = _imported(tmp_path, records, capsys, "--image-topic", "/cam/image_raw")
    assert "the configuration its messages give is invalid" in err
    assert "/cam/camera_info (CameraInfo)" in err
    assert "config.yaml" not in err.split("invalid")[0]


@pytest.mark.parametrize(
    ("transforms", "expected"),
    [
        ([("base_link", "mast", (0, 0, 1), (0, 0, 0, 0))], "is no quaternion"),
        ([("base_link", "mast", (0, 0, 1), (NAN, 0, 0, 1))], "is no quaternion"),
        (
            [
                ("base_link", "mast", (0, 0, 1), (0, 0, 0, 1)),
                ("odom", "mast", (0, 0, 1), (0, 0, 0, 1)),
            ],
            "mast has another parent, base_link",
        ),
        (
            [
                ("base_link", "mast", (0, 0, 1), (0, 0, 0, 1)),
                ("mast", "gps", (0, 0, 1), (0, 0, 0, 1)),
                ("gps", "base_link", (0, 0, 1), (0, 0, 0, 1)),
            ],
            "closes a loop of frames (base_link is above gps)",
        ),
    ],
)
def test_tf_static_that_makes_no_tree_is_one_line(
    transforms: list, expected: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    records = [("/tf_static", "tf2_msgs/msg/TFMessage", NS[0], M.tf_static(NS[0], transforms))]
    err = _imported(tmp_path, records, capsys)
    assert "/tf_static" in err and expected in err


def test_an_outlying_header_stamp_is_dropped_and_counted(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A stamp of 2**31 - 1 s in one message: dropped (said so), not a segment 68 years away."""
    records = _odometry({})
    far = (2**31 - 1) * 10**9
    records[10] = ("/odom", "nav_msgs/msg/Odometry", NS[10], M.odometry(far, twist=(0.5, 0.2)))
    bag, out = _bag(tmp_path, records), tmp_path / "out"
    argv = ["import", str(bag), "--out", str(out), "--wheels-topic", "/odom", "--track-width", "1"]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert printed.startswith("40 rows over 2.0 s (1 segment)")
    assert "header stamp over 3600 s away from the others'" in printed
    assert len(read_wheel_log(out / "log.csv").run_ranges()) == 1
