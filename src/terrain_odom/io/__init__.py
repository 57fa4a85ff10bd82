"""Reading and writing the files of terrain-odom: wheel logs and trajectories."""

from terrain_odom.io.trajectory import TrajectoryWriter, read_trajectory_csv, write_tum
from terrain_odom.io.wheel_log import read_wheel_log, write_wheel_log

__all__ = [
    "TrajectoryWriter",
    "read_trajectory_csv",
    "read_wheel_log",
    "write_tum",
    "write_wheel_log",
]
