"""Building the live odometry from a configuration file: the checks before the node starts."""

from __future__ import annotations

from pathlib import Path

import pytest

from terrain_odom.app.live.build import build_live
from terrain_odom.app.live.options import LiveTopics
from terrain_odom.errors import ConfigError

ODOM, IMU_TOPIC = "/jackal_velocity_controller/odom", "/imu/data"


def test_the_heading_bias_without_a_pose_topic_is_refused(tmp_path: Path) -> None:
    """As ``run`` on a log without positions: nothing would observe the bias (one line)."""
    config = tmp_path / "bias.yaml"
    config.write_text("pose_sensor: {heading_bias: true}\n", encoding="utf-8")
    with pytest.raises(ConfigError, match="no --pose-topic: headings but no positions"):
        build_live(config, LiveTopics(ODOM, heading=IMU_TOPIC))
