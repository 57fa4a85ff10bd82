"""One pass over a bag without writing anything: :func:`~terrain_odom.io.bag.contents.read_bag`.

On the real Jackal bag (``../shared/data/bags/jackal_odom_imu.bag``): the
contents agree with the in-memory log and with the counts ``inspect`` and
the import test (tests/app/test_bag_real.py) find by other routes.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from terrain_odom.errors import ConfigError
from terrain_odom.io.bag.contents import check_options, read_bag, read_bag_log
from terrain_odom.io.bag.options import ImportOptions

ODOM, IMU = "/jackal_velocity_controller/odom", "/imu/data"
TRACK = 0.563


def test_contents_of_the_real_bag(jackal_bag: Path) -> None:
    options = ImportOptions(ODOM, heading_topic=IMU, track_width=TRACK)
    robot = check_options(options)
    assert robot == {"track_width": TRACK, "wheel_radius": None}
    contents = read_bag(jackal_bag, options, robot, None, progress=False)
    log = read_bag_log(jackal_bag, options, progress=False)
    np.testing.assert_array_equal(contents.log.t, log.t)
    np.testing.assert_array_equal(contents.log.v_l, log.v_l)
    assert (len(contents.log), contents.wheel_messages, contents.origin_ns) == (
        6119,
        3060,
        47 * 10**9,
    )
    assert contents.topics == {ODOM: "nav_msgs/msg/Odometry", IMU: "sensor_msgs/msg/Imu"}
    assert contents.skipped == {"merge": {"heading outside the wheel samples": 2}}
    assert (contents.frame_files, contents.camera, contents.gps_origin) == ((), None, None)
    assert contents.config.data["robot"] == {"track_width": TRACK}
    assert contents.config.sources["robot.track_width"] == "--track-width"
    assert contents.config.fill_keys == ()


def test_check_options_refuses_before_reading() -> None:
    with pytest.raises(ConfigError, match="--max-gap"):
        check_options(ImportOptions(ODOM, track_width=TRACK, max_gap=0.0))
