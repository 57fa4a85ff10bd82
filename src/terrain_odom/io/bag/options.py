"""What to read from a ROS bag and how: :class:`ImportOptions` (the options of ``terrain-odom import``).

Light (no ``rosbags``, no OpenCV): the CLI builds the options of every
command that reads a bag, bag or not.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

__all__ = ["FRAMES_DIR", "STAMP_CHOICES", "ImportOptions"]

STAMP_CHOICES = ("header", "receive")
FRAMES_DIR = "frames"
"""The folder of an import's frames, in ``OUT``."""


@dataclass(frozen=True)
class ImportOptions:
    """What to read from a bag and how (the options of ``terrain-odom import``).

    Attributes
    ----------
    wheels_topic : str
        JointState, Odometry or TwistStamped topic.
    pose_topic, heading_topic, image_topic, camera_info_topic : str, optional
        Pose (Odometry, PoseStamped, PoseWithCovarianceStamped, /tf,
        NavSatFix), heading (Imu), image (Image, CompressedImage) and
        camera-info topics. The camera-info topic defaults to the image
        topic's sibling ``camera_info`` (used when present).
    track_width, wheel_radius : float, optional
        m; default the configuration's when ``config_path`` is given. The track
        width converts a body twist, the wheel radius joint velocities.
    left_joints, right_joints : tuple of str
        Shell patterns of the JointState joints of each side (averaged).
    pose_frames : (str, str), optional
        Parent and child frame of the ``/tf`` pose.
    base_frame : str
        The robot's frame, for the mountings from ``/tf_static``: the
        image's ``frame_id``, the pose sensor's frame (a NavSatFix's
        ``frame_id``, an Odometry's ``child_frame_id``, the ``/tf`` pose's
        child) and the Imu's ``frame_id``, each in it.
    gps_origin : (float, float, float), optional
        ENU origin: latitude, longitude (deg), altitude (m).
    stamps : {'header', 'receive'}
        Message header stamps, or the bag's receive times.
    max_gap : float
        s; a longer gap between wheel messages starts a new segment.
    image_format : {'jpg', 'png'}
    config_path : str or Path, optional
        A project configuration to start ``config.yaml`` from.
    """

    wheels_topic: str
    pose_topic: str | None = None
    heading_topic: str | None = None
    image_topic: str | None = None
    camera_info_topic: str | None = None
    track_width: float | None = None
    wheel_radius: float | None = None
    left_joints: tuple[str, ...] = ("*left*",)
    right_joints: tuple[str, ...] = ("*right*",)
    pose_frames: tuple[str, str] | None = None
    base_frame: str = "base_link"
    gps_origin: tuple[float, float, float] | None = None
    stamps: str = "header"
    max_gap: float = 0.5
    image_format: str = "jpg"
    config_path: str | Path | None = None
