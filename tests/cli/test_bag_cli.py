"""``terrain-odom inspect`` and ``import``: what they print, exit codes, bad input; the real bag."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from terrain_odom.cli.main import main
from terrain_odom.config import load_config
from terrain_odom.estimation import odometry, online
from terrain_odom.estimation.icr_ekf_reference import FilterpyIcrEkf
from terrain_odom.io.bag.writer import MessageFactory, write_bag
from terrain_odom.io.wheel_log import read_wheel_log
from tests.conftest import SHARED_DATA

M = MessageFactory()
BASE = 1_700_000_000 * 10**9
STEP = 100_000_000
JACKAL_ODOM = "/jackal_velocity_controller/odom"


@pytest.fixture
def bag(tmp_path: Path) -> Path:
    """Write a 1-s MCAP bag: Odometry at 20 Hz, Imu at 10 Hz."""
    records = [
        (
            "/odom",
            "nav_msgs/msg/Odometry",
            BASE + k * 50_000_000,
            M.odometry(BASE + k * 50_000_000, twist=(0.5, 0.2)),
        )
        for k in range(21)
    ] + [
        (
            "/imu/data",
            "sensor_msgs/msg/Imu",
            BASE + k * 100_000_000 + 7_000_000,
            M.imu(BASE + k * 100_000_000 + 7_000_000, 0.1 * k),
        )
        for k in range(10)
    ]
    folder = write_bag(tmp_path / "rec", "mcap", sorted(records, key=lambda r: r[2]))
    return next(folder.glob("*.mcap"))


def test_inspect_prints_every_topic_with_its_roles(
    bag: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["inspect", str(bag)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == f"bag:      {bag} (MCAP)"
    assert out[1] == "messages: 31 over 1.0 s"
    assert out[3].split() == ["/imu/data", "sensor_msgs/Imu", "10", "10.0", "0.9", "heading"]
    assert out[4].split() == ["/odom", "nav_msgs/Odometry", "21", "20.0", "1.0", "wheels,", "pose"]


def test_import_prints_counts_and_files(
    bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out_dir = tmp_path / "out"
    argv = [
        "import",
        str(bag),
        "--out",
        str(out_dir),
        "--wheels-topic",
        "/odom",
        "--heading-topic",
        "/imu/data",
        "--track-width",
        "0.4",
    ]
    assert main(argv) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith(
        "31 rows over 1.0 s (1 segment): 0 with x, y, 10 with yaw; 0 frames;"
    )
    assert lines[1:] == [
        f"log:        {out_dir / 'log.csv'}",
        f"config:     {out_dir / 'config.yaml'}",
        f"report:     {out_dir / 'import.json'}",
    ]
    log = read_wheel_log(out_dir / "log.csv")
    np.testing.assert_allclose([log.v_l[0], log.v_r[0]], [0.46, 0.54])  # 0.5 -+ 0.2 * 0.4 / 2


def test_import_names_the_mounting_from_tf_static_and_the_antenna_to_fill(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    odom = [
        ("/odom", "nav_msgs/msg/Odometry", BASE + k * STEP, M.odometry(BASE + k * STEP))
        for k in range(10)
    ]
    fixes = [
        ("/fix", "sensor_msgs/msg/NavSatFix", BASE + STEP + 1, M.nav_sat_fix(BASE + STEP + 1, 0, 0))
    ]
    mast = ("base_link", "gps", (-0.3, 0.1, 0.8), (0.0, 0.0, 0.0, 1.0))
    tf = [("/tf_static", "tf2_msgs/msg/TFMessage", BASE, M.tf_static(BASE, [mast]))]
    argv = ["import", "--wheels-topic", "/odom", "--pose-topic", "/fix", "--track-width", "0.4"]
    for name, records in (("tf", odom + fixes + tf), ("none", odom + fixes)):
        bag = write_bag(tmp_path / f"{name}.bag", "ros1", sorted(records, key=lambda r: r[2]))
        assert main([*argv, str(bag), "--out", str(tmp_path / name)]) == 0
    lines = capsys.readouterr().out.splitlines()
    config = tmp_path / "tf" / "config.yaml"
    assert (
        f"mounting:   pose_sensor.antenna_x, pose_sensor.antenna_y from /tf_static (in {config})"
        in lines
    )
    config = tmp_path / "none" / "config.yaml"
    assert f"fill in:    pose_sensor.antenna_x, pose_sensor.antenna_y (in {config})" in lines
    sensor = yaml.safe_load((tmp_path / "tf" / "config.yaml").read_text())["pose_sensor"]
    assert sensor == {"antenna_x": -0.3, "antenna_y": 0.1}


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (
            ["--wheels-topic", "/imu/data"],
            "--wheels-topic /imu/data: type sensor_msgs/Imu, expected",
        ),
        (["--wheels-topic", "/odom"], "body twist (nav_msgs/Odometry): give --track-width"),
        (
            ["--wheels-topic", "/cmd_vel", "--track-width", "1"],
            "--wheels-topic /cmd_vel: no such topic",
        ),
        (["--wheels-topic", "/odom", "--track-width", "1", "--max-gap", "0"], "--max-gap must be"),
    ],
)
def test_bad_input_is_one_line_exit_2(
    bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], extra: list[str], message: str
) -> None:
    assert main(["import", str(bag), "--out", str(tmp_path / "o"), *extra]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and err.startswith("terrain-odom: error: ")


def test_not_a_bag_is_one_line_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "log.bag"
    path.write_text("t,v_l,v_r\n")
    assert main(["inspect", str(path)]) == 2
    err = capsys.readouterr().err
    assert (
        err
        == f"terrain-odom: error: {path}: not a readable ROS bag (File magic is invalid.); expected a ROS 1 .bag file, a ROS 2 bag folder (metadata.yaml) or a .mcap file\n"
    )


def test_run_reads_a_bag_through_the_import(
    bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    topics = ["--wheels-topic", "/odom", "--heading-topic", "/imu/data", "--track-width", "0.4"]
    direct = tmp_path / "direct"
    assert (
        main(
            ["run", "--wheels", str(bag), "--out", str(direct), "--estimator", "slip-ekf", *topics]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert f"log:        {direct / 'bag' / 'log.csv'}" in out
    assert main(["import", str(bag), "--out", str(tmp_path / "imp"), *topics]) == 0
    argv = [
        "run",
        "--wheels",
        str(tmp_path / "imp" / "log.csv"),
        "--config",
        str(tmp_path / "imp" / "config.yaml"),
        "--out",
        str(tmp_path / "csv"),
        "--estimator",
        "slip-ekf",
    ]
    assert main(argv) == 0
    assert (direct / "trajectory.csv").read_text() == (
        tmp_path / "csv" / "trajectory.csv"
    ).read_text()


@pytest.mark.parametrize(
    ("wheels", "extra", "message"),
    [
        ("bag", [], "is a ROS bag: give --wheels-topic"),
        ("csv", ["--wheels-topic", "/odom"], "--wheels-topic reads a ROS bag, but --wheels"),
    ],
)
def test_run_bag_options_misused(
    bag: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    wheels: str,
    extra: list[str],
    message: str,
) -> None:
    csv = tmp_path / "log.csv"
    csv.write_text("t,v_l,v_r\n0,1,1\n0.1,1,1\n")
    path = bag if wheels == "bag" else csv
    assert main(["run", "--wheels", str(path), "--out", str(tmp_path / "o"), *extra]) == 2
    assert message in capsys.readouterr().err


def test_run_on_a_bag_refuses_a_run_folder_before_importing(
    bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = [
        "run",
        "--wheels",
        str(bag),
        "--out",
        str(tmp_path),
        "--wheels-topic",
        "/odom",
        "--track-width",
        "0.4",
    ]
    assert main(argv) == 0
    log = (tmp_path / "bag" / "log.csv").read_bytes()
    (tmp_path / "bag" / "log.csv").write_bytes(b"kept")
    capsys.readouterr()
    assert main(argv) == 2
    assert "already holds a run" in capsys.readouterr().err
    assert (tmp_path / "bag" / "log.csv").read_bytes() == b"kept"  # nothing imported
    # the edited log is the user's now: even --overwrite keeps it, in one line
    assert main([*argv, "--overwrite"]) == 2
    assert "log.csv: edited since terrain-odom import wrote it" in capsys.readouterr().err
    assert (tmp_path / "bag" / "log.csv").read_bytes() == b"kept"
    (tmp_path / "bag" / "log.csv").unlink()
    assert main([*argv, "--overwrite"]) == 0
    assert (tmp_path / "bag" / "log.csv").read_bytes() == log


@pytest.fixture(scope="module")
def jackal(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Import the real Jackal bag as docs/bags.md does (skipped without ../shared)."""
    bag = SHARED_DATA / "bags" / "jackal_odom_imu.bag"
    if not bag.is_file():
        pytest.skip(f"real data not present: {bag} (../shared beside the repository)")
    out = tmp_path_factory.mktemp("jackal")
    argv = ["import", str(bag), "--out", str(out), "--wheels-topic", JACKAL_ODOM]
    assert main([*argv, "--heading-topic", "/imu/data", "--track-width", "0.563"]) == 0
    return out


def test_real_bag_import_writes_the_documented_config(jackal: Path) -> None:
    assert yaml.safe_load((jackal / "config.yaml").read_text()) == {
        "robot": {"track_width": 0.563},
        "ekf": {"sigma_r": {"yaw": 0.005}},
        "slip_ekf": {"sigma_r": {"dyaw": 0.00707107}},
    }
    sources = json.loads((jackal / "import.json").read_text())["config_sources"]
    assert sources["ekf.sigma_r.yaw"] == "/imu/data orientation covariances (median of 3061)"


@pytest.mark.parametrize(
    ("estimator", "path_m", "alpha"), [("icr-ekf", 101.6, 1.0), ("slip-ekf", 84.2, 1.0)]
)
def test_real_bag_both_estimators_update_on_every_heading(
    jackal: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    estimator: str,
    path_m: float,
    alpha: float,
) -> None:
    """The figures of docs/bags.md: 3058 updates, the IMU's heading; alpha held by both.

    Headings alone cannot tell alpha from the ICR spacing: both estimators
    keep alpha 1 (the ICR EKF ended at 0.32 and 36.7 m before it held it).
    """
    out = tmp_path / "run"
    argv = ["run", "--wheels", str(jackal / "log.csv"), "--config", str(jackal / "config.yaml")]
    assert main([*argv, "--out", str(out), "--estimator", estimator]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[1] == "pose:       position 0 of 0 used, heading 3059 of 3059"
    report = json.loads((out / "report.json").read_text())
    assert report["counts"]["updates"] == 3058 and report["warnings"] == []
    assert "| heading | 3059 | 3059 | 0 |" in (out / "report.md").read_text()
    run = np.genfromtxt(out / "trajectory.csv", delimiter=",", names=True)
    log = read_wheel_log(jackal / "log.csv")
    off = np.angle(np.exp(1j * (run["yaw"] - log.pose[:, 2])))[log.has_yaw]
    assert np.abs(off).max() < 0.03  # 0.025 rad (ICR EKF), 0 (slip EKF: reset to each heading)
    path = np.hypot(np.diff(run["x"]), np.diff(run["y"])).sum()
    assert (path, run["alpha"][-1]) == pytest.approx((path_m, alpha), abs=0.05)
    if estimator == "icr-ekf":  # the spacing takes the turn; x_icr never correlates with yaw
        # from +-track_width / 2 (it started at a built-in +-0.25 m: 2.30 m and 94.0 m then)
        assert run["y_l"][-1] - run["y_r"][-1] == pytest.approx(2.42, abs=0.01)
        assert np.all(run["x_icr"] == 0.0) and np.all(run["alpha"] == 1.0)


def test_real_bag_icr_ekf_kernels_equal_filterpy_holding_alpha(
    jackal: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Headings alone on a real log: the kernels equal the reference (Schmidt update) to 1e-12."""
    log = read_wheel_log(jackal / "log.csv")
    cfg = load_config(jackal / "config.yaml")
    fast = odometry.run_icr_ekf(log, cfg)
    monkeypatch.setattr(online, "IcrEkf", FilterpyIcrEkf)
    slow = odometry.run_icr_ekf(log, cfg)
    assert fast.n_updates == slow.n_updates == 3058
    np.testing.assert_allclose(fast.states, slow.states, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fast.stds, slow.stds, rtol=0, atol=1e-12)
    assert np.all(fast.states[:, 6] == 1.0) and np.all(fast.states[:, 5] == 0.0)
