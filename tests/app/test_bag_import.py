"""``import_bag`` on ROS 1, ROS 2 sqlite3 and MCAP bags written here with known content."""

from __future__ import annotations

import json
import math
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

from terrain_odom.app.bag_import import import_bag
from terrain_odom.config import load_config
from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.io.bag.options import ImportOptions
from terrain_odom.io.bag.reader import summarize_bag
from terrain_odom.io.bag.writer import MessageFactory, write_bag
from terrain_odom.io.frames import read_frames
from terrain_odom.io.wheel_log import read_wheel_log

M = MessageFactory()
SEC = 1_700_000_000
BASE = SEC * 10**9 + 500_000_000  # wheel k at t = 0.5 + 0.1 k on the log's clock (origin SEC)
STEP = 100_000_000
JOINTS = ["front_left_wheel", "rear_left_wheel", "front_right_wheel", "rear_right_wheel"]
WHEEL_KS = [*range(10), *range(15, 20)]  # a 0.6-s gap: two segments


def _wheel_records(swap: bool = True) -> list:
    """JointState: left joints k and k + 2 rad/s, right joints 2k; header stamps of 5 and 6 swapped."""
    records = []
    for k in WHEEL_KS:
        stamp_k = {5: 6, 6: 5}.get(k, k) if swap else k
        msg = M.joint_state(BASE + stamp_k * STEP, JOINTS, [k, k + 2, 2 * k, 2 * k])
        records.append(("/joint_states", "sensor_msgs/msg/JointState", BASE + k * STEP + 1000, msg))
    return records


def _known_bag(folder: Path, kind: str) -> Path:
    """Wheels, two PoseStamped, three Imu headings (one on a pose row), in receive order."""
    records = _wheel_records()
    records += [
        (
            "/pose",
            "geometry_msgs/msg/PoseStamped",
            BASE + 250_000_000,
            M.pose_stamped(BASE + 250_000_000, 1.0, 2.0, 0.3),
        ),
        (
            "/pose",
            "geometry_msgs/msg/PoseStamped",
            BASE + 1_200_000_000,
            M.pose_stamped(BASE + 1_200_000_000, 5.0, -1.0, -3.0),
        ),
        ("/imu", "sensor_msgs/msg/Imu", BASE + 320_000_000, M.imu(BASE + 320_000_000, 2.0)),
        ("/imu", "sensor_msgs/msg/Imu", BASE + 250_000_000, M.imu(BASE + 250_000_000, 1.0)),
        (
            "/imu",
            "sensor_msgs/msg/Imu",
            BASE - 1000,
            M.imu(BASE - 1000, 1.0),
        ),  # 1 us before the wheels
    ]
    records.sort(key=lambda r: r[2])
    name = "known.bag" if kind == "ros1" else f"known_{kind}"
    return write_bag(folder / name, kind, records)


OPTIONS = ImportOptions(
    wheels_topic="/joint_states",
    pose_topic="/pose",
    heading_topic="/imu",
    wheel_radius=0.5,
    track_width=0.6,
)


def _single_mcap(folder: Path) -> Path:
    return next(_known_bag(folder, "mcap").glob("*.mcap"))


@pytest.mark.parametrize("kind", ["ros1", "sqlite3", "mcap", "mcap-file"])
def test_known_bag_imports_exactly(tmp_path: Path, kind: str) -> None:
    bag = _single_mcap(tmp_path) if kind == "mcap-file" else _known_bag(tmp_path, kind)
    result = import_bag(bag, tmp_path / "out", OPTIONS, progress=False)
    log = read_wheel_log(result.log_csv)
    wheel_t = [0.5 + 0.1 * k for k in WHEEL_KS]
    expected_t = sorted([*wheel_t, 0.75, 0.82, 1.7])
    np.testing.assert_allclose(log.t, expected_t, atol=1e-9)
    # speeds: v_l = 0.5 * mean(k, k + 2) = 0.5 (k + 1), v_r = 0.5 * 2k = k; pose rows hold the
    # speeds of the wheel row before them; the swapped header stamps are sorted by stamp: the
    # row stamped 5 carries the message received sixth (k = 6)
    ks = np.array([{5: 6, 6: 5}.get(k, k) for k in WHEEL_KS])
    on_wheel_rows = np.isin(np.round(log.t, 6), np.round(wheel_t, 6))
    np.testing.assert_allclose(log.v_l[on_wheel_rows], 0.5 * (ks + 1))
    np.testing.assert_allclose(log.v_r[on_wheel_rows], ks)
    row = {round(float(t), 2): i for i, t in enumerate(log.t)}
    assert (log.v_l[row[0.75]], log.v_r[row[0.75]]) == (1.5, 2.0)  # held from k = 2
    np.testing.assert_allclose(log.pose[row[0.75]], [1.0, 2.0, 0.3])  # pose yaw beats the Imu
    np.testing.assert_allclose(log.pose[row[0.82]], [np.nan, np.nan, 2.0])  # heading-only row
    np.testing.assert_allclose(log.pose[row[1.7]], [5.0, -1.0, -3.0])
    assert (
        log.segment.tolist() == [0] * 13 + [1] * 5
    )  # 0.6-s gap after k = 9; the pose at 1.7 s is 0.3 s into it
    assert result.rows == 18 and result.segments == 2 and result.heading_rows == 3
    report = json.loads(result.import_json.read_text())
    assert report["time_origin_ns"] == SEC * 10**9
    assert report["skipped"]["merge"] == {
        "heading outside the wheel samples": 1,
        "heading on the row of a pose with yaw": 1,
    }
    assert report["counts"]["wheel_messages_out_of_order"] == 1
    cfg = load_config(result.config_yaml)
    assert (cfg.robot.wheel_radius, cfg.robot.track_width) == (0.5, 0.6)
    assert cfg.ekf.sigma_r.yaw == pytest.approx(0.01)  # the Imu covariance's std dev


def test_receive_stamps_keep_bag_order(tmp_path: Path) -> None:
    bag = write_bag(tmp_path / "w.bag", "ros1", _wheel_records())
    opts = ImportOptions(wheels_topic="/joint_states", wheel_radius=0.5, stamps="receive")
    log = read_wheel_log(import_bag(bag, tmp_path / "out", opts, progress=False).log_csv)
    np.testing.assert_allclose(log.t, [0.5 + 0.1 * k + 1e-6 for k in WHEEL_KS], atol=1e-9)
    assert log.v_r[5] == 5.0  # the message received fifth, whatever its header says


def test_twists_become_track_speeds(tmp_path: Path) -> None:
    records = [
        (
            "/odom",
            "nav_msgs/msg/Odometry",
            BASE + k * STEP,
            M.odometry(BASE + k * STEP, twist=(1.0, 0.5 * k), sigma=(0.1, 0.2, 0.05)),
        )
        for k in range(5)
    ] + [
        (
            "/cmd",
            "geometry_msgs/msg/TwistStamped",
            BASE + k * STEP,
            M.twist_stamped(BASE + k * STEP, -0.5, 1.0),
        )
        for k in range(5)
    ]
    bag = write_bag(tmp_path / "t.mcap.d", "mcap", records)
    odom = import_bag(
        bag,
        tmp_path / "a",
        ImportOptions("/odom", pose_topic="/odom", track_width=0.8),
        progress=False,
    )
    log = read_wheel_log(odom.log_csv)
    omega = 0.5 * np.arange(5)
    np.testing.assert_allclose(log.v_l, 1.0 - omega * 0.4)  # v - omega B / 2
    np.testing.assert_allclose(log.v_r, 1.0 + omega * 0.4)
    assert log.has_pose.all()  # the same topic as wheels and pose: one row per message
    sigma = load_config(odom.config_yaml).ekf.sigma_r
    assert (sigma.x, sigma.y, sigma.yaw) == pytest.approx((0.1, 0.2, 0.05))
    cmd = import_bag(bag, tmp_path / "b", ImportOptions("/cmd", track_width=0.8), progress=False)
    log = read_wheel_log(cmd.log_csv)
    np.testing.assert_allclose([log.v_l[0], log.v_r[0]], [-0.9, -0.1])


def _pose_bag(folder: Path, pose_records: list) -> Path:
    wheels = [
        ("/odom", "nav_msgs/msg/Odometry", BASE + k * STEP, M.odometry(BASE + k * STEP))
        for k in range(10)
    ]
    return write_bag(folder / "p.bag", "ros1", sorted(wheels + pose_records, key=lambda r: r[2]))


def test_tf_pose_between_the_frames_asked_for(tmp_path: Path) -> None:
    records = [
        (
            "/tf",
            "tf2_msgs/msg/TFMessage",
            BASE + 3 * STEP,
            M.tf(BASE + 3 * STEP, [("odom", "base_link", 1.0, 2.0, 0.4), ("map", "odom", 9, 9, 1)]),
        ),
        (
            "/tf",
            "tf2_msgs/msg/TFMessage",
            BASE + 5 * STEP,
            M.tf(BASE + 5 * STEP, [("map", "odom", 7.0, 7.0, 1.0)]),
        ),
    ]
    bag = _pose_bag(tmp_path, records)
    opts = ImportOptions(
        "/odom", pose_topic="/tf", track_width=0.5, pose_frames=("/odom", "base_link")
    )
    log = read_wheel_log(import_bag(bag, tmp_path / "out", opts, progress=False).log_csv)
    assert np.count_nonzero(log.has_pose) == 1
    np.testing.assert_allclose(log.pose[3], [1.0, 2.0, 0.4])
    bad = ImportOptions("/odom", pose_topic="/tf", track_width=0.5, pose_frames=("odom", "gps"))
    with pytest.raises(InputFileError, match=r"/tf: no transform odom -> gps .*map -> odom"):
        import_bag(bag, tmp_path / "bad", bad, progress=False)


def test_pose_with_covariance(tmp_path: Path) -> None:
    records = [
        (
            "/amcl",
            "geometry_msgs/msg/PoseWithCovarianceStamped",
            BASE + 2 * STEP,
            M.pose_cov_stamped(BASE + 2 * STEP, 3.0, 4.0, -0.5, 0.3),
        )
    ]
    result = import_bag(
        _pose_bag(tmp_path, records),
        tmp_path / "out",
        ImportOptions("/odom", pose_topic="/amcl", track_width=0.5),
        progress=False,
    )
    log = read_wheel_log(result.log_csv)
    np.testing.assert_allclose(log.pose[2], [3.0, 4.0, -0.5])
    assert load_config(result.config_yaml).ekf.sigma_r.x == pytest.approx(0.3)


def test_navsatfix_to_local_east_north(tmp_path: Path) -> None:
    # 0.001 deg on the equator: east a * pi / 180e3 = 111.3195 m, north a (1 - e^2) pi / 180e3
    a, e2 = 6378137.0, 0.00669437999014
    east, north = a * math.pi / 180e3, a * (1 - e2) * math.pi / 180e3
    records = [
        (
            "/fix",
            "sensor_msgs/msg/NavSatFix",
            BASE + STEP,
            M.nav_sat_fix(BASE + STEP, 0, 0, status=-1),
        ),
        (
            "/fix",
            "sensor_msgs/msg/NavSatFix",
            BASE + 2 * STEP,
            M.nav_sat_fix(BASE + 2 * STEP, 0, 0, sigma=0.4),
        ),
        (
            "/fix",
            "sensor_msgs/msg/NavSatFix",
            BASE + 4 * STEP,
            M.nav_sat_fix(BASE + 4 * STEP, 0, 0.001),
        ),
        (
            "/fix",
            "sensor_msgs/msg/NavSatFix",
            BASE + 6 * STEP,
            M.nav_sat_fix(BASE + 6 * STEP, 0.001, 0),
        ),
    ]
    bag = _pose_bag(tmp_path, records)
    result = import_bag(
        bag,
        tmp_path / "out",
        ImportOptions("/odom", pose_topic="/fix", track_width=0.5),
        progress=False,
    )
    log = read_wheel_log(result.log_csv)
    np.testing.assert_allclose(log.pose[[2, 4, 6], :2], [[0, 0], [east, 0], [0, north]], atol=1e-3)
    assert np.isnan(log.pose[:, 2]).all()  # GPS has no heading
    assert result.skipped["--pose-topic /fix"] == {
        "GPS fix without a solution (status < 0 or NaN)": 1
    }
    assert load_config(result.config_yaml).ekf.sigma_r.x == pytest.approx(0.4)
    origin = ImportOptions(
        "/odom", pose_topic="/fix", track_width=0.5, gps_origin=(0.0, -0.001, 0.0)
    )
    log = read_wheel_log(import_bag(bag, tmp_path / "o2", origin, progress=False).log_csv)
    np.testing.assert_allclose(log.pose[2, :2], [east, 0], atol=1e-3)


def test_images_and_camera_info(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    raw = rng.integers(0, 255, (24, 32, 3), dtype=np.uint8)
    jpeg = cv2.imencode(".jpg", raw)[1].tobytes()
    records = [
        ("/cam/image_raw", "sensor_msgs/msg/Image", BASE + 3 * STEP, M.image(BASE + 3 * STEP, raw)),
        ("/cam/image_raw", "sensor_msgs/msg/Image", BASE + 2 * STEP, M.image(BASE + 2 * STEP, raw)),
        (
            "/cam/camera_info",
            "sensor_msgs/msg/CameraInfo",
            BASE,
            M.camera_info(BASE, 32, 24, 40.0, 15.5, 11.5),
        ),
        (
            "/cam/compressed",
            "sensor_msgs/msg/CompressedImage",
            BASE + STEP,
            M.compressed_image(BASE + STEP, jpeg),
        ),
    ]
    bag = _pose_bag(tmp_path, records)
    opts = ImportOptions("/odom", image_topic="/cam/image_raw", track_width=0.5, image_format="png")
    result = import_bag(bag, tmp_path / "out", opts, progress=False)
    frames = read_frames(tmp_path / "out")
    assert [round(t, 6) for t in frames.t] == [0.7, 0.8]  # sorted by stamp
    np.testing.assert_array_equal(cv2.imread(str(frames.files[0])), raw)  # png: lossless, BGR kept
    cfg = yaml.safe_load(result.config_yaml.read_text())
    assert cfg["camera"] == {
        "width": 32,
        "height": 24,
        "fx": 40.0,
        "fy": 40.0,
        "cx": 15.5,
        "cy": 11.5,
    }
    assert result.fill_keys == tuple(
        f"camera.mount_{k}" for k in ("x", "y", "height", "pitch", "yaw")
    )
    assert "FILL IN" in result.config_yaml.read_text()
    comp = ImportOptions("/odom", image_topic="/cam/compressed", track_width=0.5)
    import_bag(bag, tmp_path / "c", comp, progress=False)
    assert (tmp_path / "c" / "frames" / "000000.jpg").read_bytes() == jpeg  # copied, not re-encoded


def test_inspect_lists_types_counts_rates_and_roles(tmp_path: Path) -> None:
    summary = summarize_bag(_known_bag(tmp_path, "sqlite3"), progress=False)
    topics = {t.topic: t for t in summary.topics}
    js = topics["/joint_states"]
    assert (js.msgtype, js.count, js.roles) == ("sensor_msgs/msg/JointState", 15, ("wheels",))
    assert js.duration == pytest.approx(1.9) and js.rate == pytest.approx(14 / 1.9)
    assert topics["/imu"].roles == ("heading",) and topics["/pose"].roles == ("pose",)
    assert summary.kind == "ROS 2 (sqlite3)" and summary.messages == 20


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (
            ImportOptions("/nope", wheel_radius=0.5),
            r"--wheels-topic /nope: no such topic .*/joint_states",
        ),
        (
            ImportOptions("/imu"),
            r"--wheels-topic /imu: type sensor_msgs/Imu, expected sensor_msgs/JointState",
        ),
        (ImportOptions("/joint_states"), r"JointState \(rad/s\): give --wheel-radius"),
        (
            ImportOptions("/joint_states", wheel_radius=0.5, heading_topic="/pose"),
            r"--heading-topic /pose: type geometry_msgs/PoseStamped, expected sensor_msgs/Imu",
        ),
        (
            ImportOptions("/joint_states", wheel_radius=0.5, left_joints=("*rear*",)),
            r"do not split into left \['\*rear\*'\]",
        ),
        (
            ImportOptions("/joint_states", wheel_radius=-1.0),
            r"--wheel-radius must be finite and > 0",
        ),
        (
            ImportOptions("/joint_states", wheel_radius=0.5, stamps="bag"),
            r"--stamps must be one of",
        ),
    ],
)
def test_bad_options_and_topics_are_one_line(
    tmp_path: Path, options: ImportOptions, message: str
) -> None:
    bag = _known_bag(tmp_path, "ros1")
    with pytest.raises((InputFileError, ConfigError), match=message) as info:
        import_bag(bag, tmp_path / "out", options, progress=False)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize(
    ("records", "options", "message"),
    [
        (
            [("/js", "sensor_msgs/msg/JointState", BASE, M.joint_state(BASE, JOINTS, []))],
            ImportOptions("/js", wheel_radius=0.5),
            r"/js: a JointState without velocities",
        ),
        (
            [("/imu", "sensor_msgs/msg/Imu", BASE, M.imu(BASE, None))],
            ImportOptions("/odom", heading_topic="/imu", track_width=0.5),
            r"/imu: an Imu topic without orientation",
        ),
        (
            [("/fix", "sensor_msgs/msg/NavSatFix", BASE, M.nav_sat_fix(BASE, 1, 1, status=-1))],
            ImportOptions("/odom", pose_topic="/fix", track_width=0.5),
            r"/fix: a NavSatFix topic without fixes",
        ),
        (
            [("/tf", "tf2_msgs/msg/TFMessage", BASE, M.tf(BASE, []))],
            ImportOptions("/odom", pose_topic="/tf", track_width=0.5),
            r"/tf is a tf2_msgs/TFMessage: give --pose-frames",
        ),
    ],
)
def test_unusable_messages_are_one_line(
    tmp_path: Path, records: list, options: ImportOptions, message: str
) -> None:
    with pytest.raises((InputFileError, ConfigError), match=message):
        import_bag(_pose_bag(tmp_path, records), tmp_path / "out", options, progress=False)


def test_topic_without_messages(tmp_path: Path) -> None:
    from rosbags.rosbag1 import Writer

    path = tmp_path / "empty.bag"
    with Writer(path) as writer:
        writer.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=M.store)
    with pytest.raises(InputFileError, match=r"--wheels-topic /odom: the topic has no messages"):
        import_bag(path, tmp_path / "out", ImportOptions("/odom", track_width=0.5), progress=False)


@pytest.mark.parametrize(
    "name", ["notabag.bag", "notabag.mcap", "notabag.txt", "folder", "missing.bag"]
)
def test_not_a_bag(tmp_path: Path, name: str) -> None:
    path = tmp_path / name
    if name == "folder":
        path.mkdir()
    elif name != "missing.bag":
        path.write_text("hello\n")
    with pytest.raises(
        InputFileError, match=r"(not a readable ROS bag|no such file).*expected a ROS 1"
    ):
        import_bag(path, tmp_path / "out", ImportOptions("/odom", track_width=0.5), progress=False)


def test_never_overwrites_an_input(tmp_path: Path) -> None:
    bag = _known_bag(tmp_path, "ros1")
    (tmp_path / "out").mkdir()
    cfg = tmp_path / "out" / "config.yaml"
    cfg.write_text("robot: {wheel_radius: 0.5}\n")
    opts = ImportOptions("/joint_states", config_path=cfg)
    with pytest.raises(InputFileError, match="refusing to overwrite the input"):
        import_bag(bag, tmp_path / "out", opts, progress=False)
    assert cfg.read_text() == "robot: {wheel_radius: 0.5}\n"
    folder = _known_bag(tmp_path, "sqlite3")
    with pytest.raises(InputFileError, match="--out is inside the bag folder"):
        import_bag(folder, folder / "out", ImportOptions("/joint_states", wheel_radius=0.5))
    assert not (folder / "out").exists()


def test_camera_mount_from_tf_static(tmp_path: Path) -> None:
    # base_link -> camera_link: 0.3 m ahead, 0.1 m left, 0.4 m up, pitched 30 deg down, turned
    # 10 deg left; camera_link -> camera_optical: the ROS optical rotation (z forward, y down)
    pitch, yaw = math.radians(30), math.radians(10)
    q = Rotation.from_euler("ZY", [yaw, pitch]).as_quat()
    records = [
        (
            "/tf_static",
            "tf2_msgs/msg/TFMessage",
            BASE,
            M.tf_static(
                BASE,
                [
                    ("base_link", "camera_link", (0.3, 0.1, 0.4), q),
                    ("camera_link", "camera_optical", (0.0, 0.0, 0.0), (-0.5, 0.5, -0.5, 0.5)),
                ],
            ),
        ),
        (
            "/cam/image_raw",
            "sensor_msgs/msg/Image",
            BASE + STEP,
            M.image(BASE + STEP, np.zeros((4, 6, 3), np.uint8), frame="camera_optical"),
        ),
    ]
    opts = ImportOptions("/odom", image_topic="/cam/image_raw", track_width=0.5)
    result = import_bag(_pose_bag(tmp_path, records), tmp_path / "out", opts, progress=False)
    camera = load_config(result.config_yaml).camera
    got = [
        camera.mount_x,
        camera.mount_y,
        camera.mount_height,
        camera.mount_pitch,
        camera.mount_yaw,
    ]
    np.testing.assert_allclose(got, [0.3, 0.1, 0.4, pitch, yaw], atol=1e-9)
    assert result.fill_keys == tuple(
        f"camera.{k}" for k in ("width", "height", "fx", "fy", "cx", "cy")
    )
    assert "mount_height is above base_link's origin" in result.config_yaml.read_text()


def test_unset_header_stamps_are_counted_or_refused(tmp_path: Path) -> None:
    records = [
        (
            "/js",
            "sensor_msgs/msg/JointState",
            BASE + k * STEP,
            M.joint_state(0 if k == 1 else BASE + k * STEP, JOINTS, [1, 1, 1, 1]),
        )
        for k in range(3)
    ]
    bag = write_bag(tmp_path / "z.bag", "ros1", records)
    result = import_bag(bag, tmp_path / "a", ImportOptions("/js", wheel_radius=0.5), progress=False)
    assert result.rows == 2
    assert result.skipped["--wheels-topic /js"] == {
        "header stamp 0 (unset; --stamps receive uses the bag's time)": 1
    }
    received = import_bag(
        bag,
        tmp_path / "b",
        ImportOptions("/js", wheel_radius=0.5, stamps="receive"),
        progress=False,
    )
    assert received.rows == 3
    unset = [("/js", "sensor_msgs/msg/JointState", BASE, M.joint_state(0, JOINTS, [1, 1, 1, 1]))]
    with pytest.raises(
        InputFileError,
        match=r"--wheels-topic /js: no message with a usable stamp \(1 header stamp 0",
    ):
        import_bag(
            write_bag(tmp_path / "u.bag", "ros1", unset),
            tmp_path / "c",
            ImportOptions("/js", wheel_radius=0.5),
            progress=False,
        )


def test_an_undecodable_image_is_one_line(tmp_path: Path) -> None:
    records = [
        (
            "/cam/compressed",
            "sensor_msgs/msg/CompressedImage",
            BASE + STEP,
            M.compressed_image(BASE + STEP, b"not an image", "png"),
        ),
    ]
    opts = ImportOptions("/odom", image_topic="/cam/compressed", track_width=0.5)
    with pytest.raises(
        InputFileError, match=r"--image-topic /cam/compressed: cannot decode the image"
    ):
        import_bag(_pose_bag(tmp_path, records), tmp_path / "out", opts, progress=False)
