"""Reading and writing every file format of terrain-odom, atomically.

Imported here: wheel logs and trajectories; the other formats (ground truth,
images, frames, classifier and parameter files, reports, output folders,
ROS bags) from their modules.
"""

from terrain_odom.io.trajectory import TrajectoryWriter, read_trajectory_csv, write_tum
from terrain_odom.io.wheel_log import read_wheel_log, write_wheel_log

__all__ = [
    "TrajectoryWriter",
    "read_trajectory_csv",
    "read_wheel_log",
    "write_tum",
    "write_wheel_log",
]
