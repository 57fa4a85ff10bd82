"""Issue 24, round two: NavSatFix fixes a receiver really sends (NaN altitude, a fix at 0/0)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from terrain_odom.cli.main import main
from terrain_odom.io.bag.messages import NAV_SAT_FIX
from terrain_odom.io.bag.reader import BagMessage
from terrain_odom.io.bag.streams import PoseStream, StampRule
from terrain_odom.io.bag.writer import MessageFactory, write_bag
from terrain_odom.io.wheel_log import read_wheel_log

M = MessageFactory()
BASE = 1_700_000_000 * 10**9
STEP = 100_000_000
N = 41
LAT, LON = 46.78, -71.27  # Quebec City
NORTH_PER_DEG = 111_132.0  # m per degree of latitude near 46.8 deg (to 0.1 %)


def _bag(tmp_path: Path, altitude: float, zero_at: int | None = None) -> Path:
    """Straight drive north at 1 m/s: Odometry twists and a fix every 0.1 s (altitude given)."""
    records = []
    for k in range(N):
        t = BASE + k * STEP
        records.append(("/odom", "nav_msgs/msg/Odometry", t, M.odometry(t, twist=(1.0, 0.0))))
        lat = LAT + 0.1 * k / NORTH_PER_DEG
        lat, lon = (0.0, 0.0) if k == zero_at else (lat, LON)
        fix = M.nav_sat_fix(t + 1000, lat, lon, alt=altitude)
        records.append(("/fix", "sensor_msgs/msg/NavSatFix", t + 1000, fix))
    folder = write_bag(tmp_path / "rec", "mcap", records)
    return next(folder.glob("*.mcap"))


def _import(bag: Path, out: Path) -> int:
    argv = ["import", str(bag), "--out", str(out), "--wheels-topic", "/odom"]
    return main([*argv, "--pose-topic", "/fix", "--track-width", "0.5"])


@pytest.mark.parametrize("altitude", [math.nan, math.inf, 120.0])
def test_a_fix_without_altitude_is_a_fix(
    altitude: float, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """ROS marks an unknown altitude NaN: the planar position is whole, 4 m north in 4 s."""
    assert _import(_bag(tmp_path, altitude), tmp_path / "out") == 0
    printed = capsys.readouterr()
    assert "RuntimeWarning" not in printed.err and "without a solution" not in printed.out
    log = read_wheel_log(tmp_path / "out" / "log.csv")
    fixes = log.pose[np.isfinite(log.pose[:, 0])]
    assert len(fixes) >= N - 1  # the last fix may come after the last wheel row
    np.testing.assert_allclose(fixes[:, 0], 0.0, atol=1e-3)
    np.testing.assert_allclose(np.diff(fixes[:, 1]), 0.1, rtol=2e-3)


def test_a_fix_at_latitude_and_longitude_zero_is_dropped_and_counted(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """One placeholder fix at 0/0 among 41 (even the first): dropped, said, the run plausible."""
    out = tmp_path / "out"
    assert _import(_bag(tmp_path, 50.0, zero_at=0), out) == 0
    printed = capsys.readouterr().out
    assert "GPS fix further from the others than a ground robot drives" in printed
    report = json.loads((out / "import.json").read_text())
    reasons = report["skipped"]["--pose-topic /fix"]
    assert list(reasons.values()) == [1] and "0/0" in next(iter(reasons))
    log = read_wheel_log(out / "log.csv")
    fixes = log.pose[np.isfinite(log.pose[:, 0])]
    assert len(fixes) >= N - 2 and np.abs(fixes[:, :2]).max() < 5.0
    run = ["run", "--wheels", str(out / "log.csv"), "--config", str(out / "config.yaml")]
    assert main([*run, "--out", str(tmp_path / "run"), "--no-plots"]) == 0


@pytest.mark.parametrize(("lat", "lon"), [(91.0, LON), (LAT, -180.5), (math.nan, LON)])
def test_a_fix_outside_the_globe_is_no_solution(
    lat: float, lon: float, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    records = [
        (
            "/odom",
            "nav_msgs/msg/Odometry",
            BASE + k * STEP,
            M.odometry(BASE + k * STEP, twist=(1.0, 0.0)),
        )
        for k in range(N)
    ]
    good = M.nav_sat_fix(BASE + 1000, LAT, LON)
    bad = M.nav_sat_fix(BASE + STEP + 1000, lat, lon)
    records += [
        ("/fix", "sensor_msgs/msg/NavSatFix", BASE + 1000, good),
        ("/fix", "sensor_msgs/msg/NavSatFix", BASE + STEP + 1000, bad),
    ]
    bag = next(write_bag(tmp_path / "rec", "mcap", sorted(records, key=lambda r: r[2])).glob("*"))
    assert _import(bag, tmp_path / "out") == 0
    assert "GPS fix without a solution" in capsys.readouterr().out


def test_a_live_stream_never_takes_its_origin_from_a_zero_fix() -> None:
    """Message by message (the ROS node's path, no median to judge by): 0/0 is skipped, counted."""
    stream = PoseStream("--pose-topic /fix", StampRule())
    for k, (lat, lon) in enumerate([(0.0, 0.0), (LAT, LON), (LAT + 1.0 / NORTH_PER_DEG, LON)]):
        t = BASE + k * STEP
        stream.add(BagMessage("/fix", NAV_SAT_FIX, t, M.nav_sat_fix(t, lat, lon, alt=50.0)))
        rows = stream.take_poses(NAV_SAT_FIX)
        assert len(rows) == (k > 0)
    assert stream.origin_used is not None and stream.origin_used[:2] == (LAT, LON)
    np.testing.assert_allclose(rows.values[0, :2], [0.0, 1.0], atol=2e-3)
    assert list(stream.skipped.values()) == [1] and "0/0" in next(iter(stream.skipped))
