"""Conversion of ROS messages (as deserialised by ``rosbags``) to terrain-odom's quantities.

Pure functions on one message each: wheel speeds from a ``JointState``, track
speeds from a body twist, a planar pose from ``Odometry``, ``PoseStamped``,
``PoseWithCovarianceStamped`` or a ``/tf`` transform, yaw from an ``Imu``,
latitude/longitude from a ``NavSatFix`` and its conversion to a local
east-north frame, camera intrinsics from ``CameraInfo``. ROS 1 and ROS 2
messages are read alike (``rosbags`` gives both the ROS 2 field names, but
for ``CameraInfo``'s upper-case ROS 1 matrices, handled here).

Coordinates follow the project: x forward, y left, yaw counter-clockwise
from x, wrapped to (-pi, pi]; a message's own world frame is kept (ENU for
GPS: x east, y north).
"""

from __future__ import annotations

import fnmatch
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from terrain_odom.kinematics.integration import wrap_angle

__all__ = [
    "JOINT_STATE",
    "ODOMETRY",
    "TWIST_STAMPED",
    "POSE_STAMPED",
    "POSE_COV_STAMPED",
    "TF_MESSAGE",
    "NAV_SAT_FIX",
    "IMU",
    "IMAGE",
    "COMPRESSED_IMAGE",
    "CAMERA_INFO",
    "ROLE_TYPES",
    "TF_STATIC",
    "Intrinsics",
    "yaw_from_quaternion",
    "stamp_ns",
    "message_type",
    "match_joints",
    "joint_speeds",
    "track_speeds",
    "planar_pose",
    "pose_sigmas",
    "tf_pose",
    "imu_yaw",
    "fix_status",
    "enu_from_geodetic",
    "intrinsics",
    "transform_matrix",
    "chain_transform",
    "camera_mount",
    "sensor_mounting",
]

JOINT_STATE = "sensor_msgs/msg/JointState"
ODOMETRY = "nav_msgs/msg/Odometry"
TWIST_STAMPED = "geometry_msgs/msg/TwistStamped"
POSE_STAMPED = "geometry_msgs/msg/PoseStamped"
POSE_COV_STAMPED = "geometry_msgs/msg/PoseWithCovarianceStamped"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
NAV_SAT_FIX = "sensor_msgs/msg/NavSatFix"
IMU = "sensor_msgs/msg/Imu"
IMAGE = "sensor_msgs/msg/Image"
COMPRESSED_IMAGE = "sensor_msgs/msg/CompressedImage"
CAMERA_INFO = "sensor_msgs/msg/CameraInfo"
TF_STATIC = "/tf_static"
"""The topic of the static transforms (the mountings)."""

#: The message types each role accepts (``inspect`` shows the roles a topic can play).
ROLE_TYPES: dict[str, tuple[str, ...]] = {
    "wheels": (JOINT_STATE, ODOMETRY, TWIST_STAMPED),
    "pose": (ODOMETRY, POSE_STAMPED, POSE_COV_STAMPED, TF_MESSAGE, NAV_SAT_FIX),
    "heading": (IMU,),
    "images": (IMAGE, COMPRESSED_IMAGE),
    "camera_info": (CAMERA_INFO,),
}

# WGS84 ellipsoid.
_A = 6378137.0
_F = 1.0 / 298.257223563
_E2 = _F * (2.0 - _F)


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics of a ``CameraInfo`` message (px); ``distortion`` as given."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    distortion: tuple[float, ...]


def yaw_from_quaternion(x: float, y: float, z: float, w: float) -> float:
    """Yaw (rad, CCW about z, wrapped to (-pi, pi]) of a rotation quaternion.

    The quaternion need not be normalised; roll and pitch are ignored (ZYX
    Euler angles).

    Examples
    --------
    >>> round(yaw_from_quaternion(0.0, 0.0, math.sin(0.3), math.cos(0.3)), 12)
    0.6
    >>> yaw_from_quaternion(0.0, 0.0, 1.0, 0.0)  # half a turn: +pi, not -pi
    3.141592653589793
    """
    yaw = math.atan2(2.0 * (w * z + x * y), w * w + x * x - y * y - z * z)
    return float(wrap_angle(yaw))


def stamp_ns(stamp: Any) -> int:
    """Nanoseconds of a message stamp.

    The one accessor of a stamp's fields: ``rosbags`` gives ROS 1 and ROS 2
    stamps alike as ``builtin_interfaces/Time`` (``sec``, ``nanosec``),
    ``rospy`` as ``rospy.Time`` (``secs``, ``nsecs``).

    Examples
    --------
    >>> from types import SimpleNamespace as Ns
    >>> stamp_ns(Ns(sec=2, nanosec=5)), stamp_ns(Ns(secs=2, nsecs=5))
    (2000000005, 2000000005)
    """
    if hasattr(stamp, "secs"):
        return int(stamp.secs) * 1_000_000_000 + int(stamp.nsecs)
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def message_type(name: str) -> str:
    """Return a message type name in ``rosbags``' form (``pkg/msg/Name``).

    ROS 1 names types ``pkg/Name`` (``rospy``'s ``_type``, a connection
    header's ``type``); the constants of this module are ``pkg/msg/Name``.

    Examples
    --------
    >>> message_type("nav_msgs/Odometry"), message_type("nav_msgs/msg/Odometry")
    ('nav_msgs/msg/Odometry', 'nav_msgs/msg/Odometry')
    """
    package, _, rest = name.partition("/")
    return name if "/" in rest else f"{package}/msg/{rest}"


def match_joints(names: Sequence[str], patterns: Sequence[str]) -> list[int]:
    """Return the indices of the joint ``names`` matching any of the shell ``patterns`` (``fnmatch``).

    Examples
    --------
    >>> match_joints(["front_left_wheel", "rear_left_wheel", "front_right_wheel"], ["*left*"])
    [0, 1]
    """
    return [
        i for i, name in enumerate(names) if any(fnmatch.fnmatchcase(name, p) for p in patterns)
    ]


def joint_speeds(
    velocity: Sequence[float], left: Sequence[int], right: Sequence[int], wheel_radius: float
) -> tuple[float, float]:
    """Track surface speeds (m/s) from joint angular velocities (rad/s): side means times radius.

    Examples
    --------
    >>> joint_speeds([2.0, 4.0, 1.0], [0, 1], [2], 0.5)
    (1.5, 0.5)
    """
    v_l = float(np.mean([velocity[i] for i in left])) * wheel_radius
    v_r = float(np.mean([velocity[i] for i in right])) * wheel_radius
    return v_l, v_r


def track_speeds(v: float, omega: float, track_width: float) -> tuple[float, float]:
    """Track speeds of a differential drive's body twist: ``v -+ omega * B / 2``.

    This inverts the ideal model a diff-drive controller uses to compute its
    odometry twist, with the controller's own wheel separation ``B``.

    Examples
    --------
    >>> track_speeds(1.0, 0.5, 0.6)
    (0.85, 1.15)
    """
    half = 0.5 * omega * track_width
    return v - half, v + half


def planar_pose(pose: Any) -> tuple[float, float, float]:
    """``x, y, yaw`` of a ``geometry_msgs/Pose`` (its position and orientation)."""
    q = pose.orientation
    return float(pose.position.x), float(pose.position.y), yaw_from_quaternion(q.x, q.y, q.z, q.w)


def pose_sigmas(covariance: Sequence[float]) -> tuple[float, float, float]:
    """Return the std devs of x, y, yaw of a row-major 6x6 pose covariance (NaN if not > 0).

    Examples
    --------
    >>> pose_sigmas([0.04] + [0.0] * 6 + [0.09] + [0.0] * 27 + [0.0])
    (0.2, 0.3, nan)
    """
    cov = np.asarray(covariance, dtype=float)
    diag = cov[[0, 7, 35]]
    out = np.where(diag > 0.0, np.sqrt(np.where(diag > 0.0, diag, 1.0)), np.nan)
    return float(out[0]), float(out[1]), float(out[2])


def tf_pose(transform: Any) -> tuple[float, float, float]:
    """``x, y, yaw`` of a ``geometry_msgs/Transform`` (translation and rotation)."""
    t, q = transform.translation, transform.rotation
    return float(t.x), float(t.y), yaw_from_quaternion(q.x, q.y, q.z, q.w)


def imu_yaw(msg: Any) -> float | None:
    """Yaw of an ``Imu`` message's orientation, or None if it has none.

    ROS marks a missing orientation with ``orientation_covariance[0] == -1``;
    an all-zero quaternion is missing too.
    """
    q = msg.orientation
    if float(msg.orientation_covariance[0]) == -1.0 or q.x == q.y == q.z == q.w == 0.0:
        return None
    return yaw_from_quaternion(q.x, q.y, q.z, q.w)


def fix_status(msg: Any) -> int:
    """Return the ``NavSatStatus`` of a ``NavSatFix``: < 0 means no fix."""
    return int(msg.status.status)


def _ecef(lat: np.ndarray, lon: np.ndarray, alt: np.ndarray) -> np.ndarray:
    """Earth-centred, earth-fixed coordinates (m) of WGS84 latitude, longitude (rad), altitude."""
    n = _A / np.sqrt(1.0 - _E2 * np.sin(lat) ** 2)
    return np.stack(
        [
            (n + alt) * np.cos(lat) * np.cos(lon),
            (n + alt) * np.cos(lat) * np.sin(lon),
            (n * (1.0 - _E2) + alt) * np.sin(lat),
        ],
        axis=-1,
    )


def enu_from_geodetic(
    lat_deg: np.ndarray, lon_deg: np.ndarray, alt: np.ndarray, origin: Sequence[float]
) -> np.ndarray:
    """East, north, up (m) of WGS84 fixes in the tangent frame at ``origin`` (lat, lon deg, alt m).

    Exact (through earth-centred coordinates), so valid far from the origin too.

    Examples
    --------
    >>> enu = enu_from_geodetic(np.array([0.0]), np.array([0.001]), np.array([0.0]), (0, 0, 0))
    >>> round(float(enu[0, 0]), 3)  # 0.001 deg of longitude on the equator: a * pi / 180e3
    111.319
    """
    lat0, lon0 = math.radians(origin[0]), math.radians(origin[1])
    p0 = _ecef(np.array(lat0), np.array(lon0), np.array(float(origin[2])))
    d = _ecef(np.radians(lat_deg), np.radians(lon_deg), np.asarray(alt, dtype=float)) - p0
    sl, cl, so, co = math.sin(lat0), math.cos(lat0), math.sin(lon0), math.cos(lon0)
    rot = np.array([[-so, co, 0.0], [-sl * co, -sl * so, cl], [cl * co, cl * so, sl]])
    return np.asarray(d @ rot.T)


def intrinsics(msg: Any) -> Intrinsics:
    """Intrinsics of a ``CameraInfo`` message (ROS 2 ``k``/``d`` or ROS 1 ``K``/``D``)."""
    k = np.asarray(msg.k if hasattr(msg, "k") else msg.K, dtype=float)
    d = msg.d if hasattr(msg, "d") else msg.D
    return Intrinsics(
        width=int(msg.width),
        height=int(msg.height),
        fx=float(k[0]),
        fy=float(k[4]),
        cx=float(k[2]),
        cy=float(k[5]),
        distortion=tuple(float(v) for v in d),
    )


def transform_matrix(transform: Any) -> np.ndarray:
    """Return the 4x4 homogeneous matrix of a ``geometry_msgs/Transform`` (child frame in the parent)."""
    q, t = transform.rotation, transform.translation
    x, y, z, w = np.array([q.x, q.y, q.z, q.w], dtype=float) / math.hypot(q.x, q.y, q.z, q.w)
    matrix = np.eye(4)
    matrix[:3, :3] = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]
    matrix[:3, 3] = [t.x, t.y, t.z]
    return matrix


def chain_transform(
    edges: dict[tuple[str, str], np.ndarray], source: str, target: str
) -> np.ndarray | None:
    """Return the pose of frame ``target`` in frame ``source`` through a tree of transforms, or None.

    ``edges`` maps ``(parent, child)`` to the child's pose in the parent
    (:func:`transform_matrix`); edges are followed both ways.

    Examples
    --------
    >>> shift = np.eye(4); shift[0, 3] = 1.0
    >>> float(chain_transform({("a", "b"): shift, ("c", "b"): shift}, "a", "c")[0, 3])
    0.0
    """
    links: dict[str, list[tuple[str, np.ndarray]]] = {}
    for (parent, child), matrix in edges.items():
        links.setdefault(parent, []).append((child, matrix))
        links.setdefault(child, []).append((parent, np.linalg.inv(matrix)))
    found = {source: np.eye(4)}
    queue = [source]
    while queue:
        frame = queue.pop(0)
        for nxt, matrix in links.get(frame, []):
            if nxt not in found:
                found[nxt] = found[frame] @ matrix
                queue.append(nxt)
    return found.get(target)


def camera_mount(pose: np.ndarray, optical: bool) -> dict[str, float]:
    """Return the ``camera.mount_*`` keys of a camera frame's pose in the robot's base frame.

    ``optical``: the frame follows the optical convention (z forward, x
    right, y down, as an image's ``header.frame_id`` usually does), else the
    body convention (x forward). ``mount_height`` is the height above the
    base frame's origin; roll is not modelled.

    Examples
    --------
    >>> down = np.eye(4); down[:3, :3] = [[0, -1, 0], [-1, 0, 0], [0, 0, -1]]; down[2, 3] = 0.5
    >>> {k: round(v, 4) for k, v in camera_mount(down, optical=True).items()}
    {'mount_x': 0.0, 'mount_y': 0.0, 'mount_height': 0.5, 'mount_pitch': 1.5708, 'mount_yaw': 0.0}
    """
    axis = pose[:3, 2] if optical else pose[:3, 0]
    pitch = -math.asin(max(-1.0, min(1.0, float(axis[2]))))
    level = math.hypot(float(axis[0]), float(axis[1]))
    yaw = math.atan2(float(axis[1]), float(axis[0])) if level > 1e-9 else 0.0
    return {
        "mount_x": float(pose[0, 3]),
        "mount_y": float(pose[1, 3]),
        "mount_height": float(pose[2, 3]),
        "mount_pitch": pitch,
        "mount_yaw": yaw,
    }


def sensor_mounting(pose: np.ndarray) -> tuple[float, float, float]:
    """Return the ``pose_sensor`` mounting of a sensor frame's pose in the robot's base frame.

    ``antenna_x, antenna_y`` (m): the frame's origin in the base frame (its
    height dropped); ``heading_offset`` (rad): the yaw of the frame's x axis
    in the base frame. A sensor that reports its own frame's orientation
    (an ``Imu``, REP 145) on a level robot reads the base's yaw plus this
    offset, whatever its roll and pitch: the yaw of ``R_z(psi) @ M`` is
    ``psi`` plus the yaw of ``M``'s first column.

    Examples
    --------
    >>> turned = np.eye(4); turned[:2, :2] = [[0, -1], [1, 0]]; turned[:3, 3] = [0.5, -0.1, 0.9]
    >>> [round(v, 4) for v in sensor_mounting(turned)]
    [0.5, -0.1, 1.5708]
    """
    yaw = math.atan2(float(pose[1, 0]), float(pose[0, 0]))
    return float(pose[0, 3]), float(pose[1, 3]), float(wrap_angle(yaw))
