"""Write ROS bags (ROS 1, ROS 2 sqlite3, ROS 2 MCAP) with ``rosbags``, and build their messages.

For tests and round trips: :class:`MessageFactory` builds the messages
``terrain-odom import`` reads (ROS 2 types of ``rosbags``' typestore, which
it serialises for ROS 1 too), :func:`write_bag` writes ``(topic, type,
receive ns, message)`` records in order.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.interfaces import Nodetype
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from scipy.spatial.transform import Rotation

from terrain_odom.config import CameraConfig
from terrain_odom.io.bag.messages import (
    CAMERA_INFO,
    COMPRESSED_IMAGE,
    IMAGE,
    IMU,
    JOINT_STATE,
    NAV_SAT_FIX,
    ODOMETRY,
    POSE_COV_STAMPED,
    POSE_STAMPED,
    TF_MESSAGE,
    TWIST_STAMPED,
)
from terrain_odom.io.frames import FrameList
from terrain_odom.records import WheelLog

__all__ = ["BAG_KINDS", "MessageFactory", "Record", "log_records", "ros1_message", "write_bag"]

#: ``ros1`` (a .bag file), ``sqlite3`` and ``mcap`` (ROS 2 bag folders).
BAG_KINDS = ("ros1", "sqlite3", "mcap")

Record = tuple[str, str, int, Any]
"""``(topic, message type, receive time ns, message)``."""


def write_bag(path: str | os.PathLike[str], kind: str, records: Iterable[Record]) -> Path:
    """Write ``records`` (in the order given) as a bag of ``kind``; return the path written.

    ``ros1`` writes the file ``path``, with ROS 1 (Noetic) message
    definitions (the messages converted: :func:`ros1_message`), so that ROS 1
    itself plays it (``rosbag play``); ``sqlite3`` and ``mcap`` write the
    bag folder ``path`` (its ``.mcap`` file alone is a bag too).
    """
    store = get_typestore(Stores.ROS2_HUMBLE)
    path = Path(path)
    writer: Any  # rosbags' two writers share the calls used here
    if kind == "ros1":
        ros1 = get_typestore(Stores.ROS1_NOETIC)  # tf2_msgs is not in it: ROS 1's definition
        ros1.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", TF_MESSAGE))
        writer = Writer1(path)
        records = ((t, k, ns, ros1_message(msg, k, ros1)) for t, k, ns, msg in records)
        store, serialize = ros1, ros1.serialize_ros1
    else:
        plugin = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
        writer = Writer2(path, version=9, storage_plugin=plugin)
        serialize = store.serialize_cdr
    with writer:
        connections: dict[str, Any] = {}
        for topic, msgtype, ns, msg in records:
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, msgtype, typestore=store)
            writer.write(connections[topic], ns, serialize(msg, msgtype))
    return path


def ros1_message(msg: Any, msgtype: str, store: Any) -> Any:
    """Return a message of ``rosbags``' ROS 2 types as the ROS 1 type of ``store`` (Noetic).

    Fields are matched by name, case aside (ROS 2's ``CameraInfo.k`` is ROS
    1's ``K``); a field ROS 2 lacks (``Header.seq``) gets its zero.

    Examples
    --------
    >>> ros1 = get_typestore(Stores.ROS1_NOETIC)
    >>> msg = ros1_message(MessageFactory().header(2 * 10**9 + 5, "map"), "std_msgs/msg/Header", ros1)
    >>> msg.seq, msg.stamp.sec, msg.stamp.nanosec, msg.frame_id
    (0, 2, 5, 'map')
    """
    _, fields = store.fielddefs[msgtype]
    names = {name.lower(): name for name in vars(msg)} if hasattr(msg, "__dict__") else {}
    names |= {f.lower(): f for f in getattr(msg, "__dataclass_fields__", {})}
    values = {}
    for name, (node, detail) in fields:
        given = names.get(name.lower())
        value = getattr(msg, given) if given is not None else None
        if node == Nodetype.NAME:
            value = (
                ros1_message(value, detail, store) if value is not None else _zero(detail, store)
            )
        elif node in (Nodetype.ARRAY, Nodetype.SEQUENCE) and detail[0][0] == Nodetype.NAME:
            value = [ros1_message(v, detail[0][1], store) for v in (value or [])]
        elif value is None:
            value = _zero_field(node, detail)
        values[name] = value
    return store.types[msgtype](**values)


def _zero(msgtype: str, store: Any) -> Any:
    """Return the all-zero message of ``msgtype``."""
    _, fields = store.fielddefs[msgtype]
    values = {}
    for name, (node, detail) in fields:
        values[name] = _zero(detail, store) if node == Nodetype.NAME else _zero_field(node, detail)
    return store.types[msgtype](**values)


def _zero_field(node: int, detail: Any) -> Any:
    """Return the zero of a base field (0, 0.0, False, '') or an empty array."""
    if node != Nodetype.BASE:
        return np.zeros(0) if node == Nodetype.SEQUENCE else []
    kind = detail[0]
    return "" if kind == "string" else (False if kind == "bool" else 0)


class MessageFactory:
    """Build ROS messages of the types ``terrain-odom import`` reads (SI units, radians)."""

    def __init__(self) -> None:
        self.store = get_typestore(Stores.ROS2_HUMBLE)
        self.t = self.store.types

    def header(self, ns: int, frame: str = "") -> Any:
        """Build a ``std_msgs/Header`` stamped ``ns`` nanoseconds."""
        stamp = self.t["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
        return self.t["std_msgs/msg/Header"](stamp=stamp, frame_id=frame)

    def quaternion(self, yaw: float) -> Any:
        """Build the rotation by ``yaw`` about z."""
        return self.t["geometry_msgs/msg/Quaternion"](
            x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2)
        )

    def _vector(self, x: float = 0.0, y: float = 0.0, z: float = 0.0) -> Any:
        return self.t["geometry_msgs/msg/Vector3"](x=x, y=y, z=z)

    def _pose(self, x: float, y: float, yaw: float) -> Any:
        point = self.t["geometry_msgs/msg/Point"](x=x, y=y, z=0.0)
        return self.t["geometry_msgs/msg/Pose"](position=point, orientation=self.quaternion(yaw))

    def _twist(self, v: float, omega: float) -> Any:
        return self.t["geometry_msgs/msg/Twist"](
            linear=self._vector(v), angular=self._vector(z=omega)
        )

    def joint_state(self, ns: int, names: Sequence[str], velocity: Sequence[float]) -> Any:
        """Build a ``JointState`` with velocities (rad/s), positions zero."""
        return self.t[JOINT_STATE](
            header=self.header(ns),
            name=list(names),
            position=np.zeros(len(names)),
            velocity=np.asarray(velocity, dtype=float),
            effort=np.zeros(0),
        )

    def odometry(
        self,
        ns: int,
        pose: Sequence[float] = (0.0, 0.0, 0.0),
        twist: Sequence[float] = (0.0, 0.0),
        sigma: Sequence[float] = (0.0, 0.0, 0.0),
    ) -> Any:
        """Build a ``Odometry``: pose ``x, y, yaw``, twist ``v, omega``, pose std devs ``x, y, yaw``."""
        cov = np.zeros(36)
        cov[[0, 7, 35]] = np.square(sigma)
        t = self.t
        return t[ODOMETRY](
            header=self.header(ns, "odom"),
            child_frame_id="base_link",
            pose=t["geometry_msgs/msg/PoseWithCovariance"](pose=self._pose(*pose), covariance=cov),
            twist=t["geometry_msgs/msg/TwistWithCovariance"](
                twist=self._twist(*twist), covariance=np.zeros(36)
            ),
        )

    def twist_stamped(self, ns: int, v: float, omega: float) -> Any:
        """Build a ``TwistStamped`` body twist."""
        return self.t[TWIST_STAMPED](header=self.header(ns), twist=self._twist(v, omega))

    def pose_stamped(self, ns: int, x: float, y: float, yaw: float) -> Any:
        """Build a ``PoseStamped``."""
        return self.t[POSE_STAMPED](header=self.header(ns, "map"), pose=self._pose(x, y, yaw))

    def pose_cov_stamped(self, ns: int, x: float, y: float, yaw: float, sigma: float) -> Any:
        """Build a ``PoseWithCovarianceStamped`` with std dev ``sigma`` on x, y and yaw."""
        cov = np.zeros(36)
        cov[[0, 7, 35]] = sigma**2
        pose = self.t["geometry_msgs/msg/PoseWithCovariance"](
            pose=self._pose(x, y, yaw), covariance=cov
        )
        return self.t[POSE_COV_STAMPED](header=self.header(ns, "map"), pose=pose)

    def tf(self, ns: int, transforms: Sequence[tuple[str, str, float, float, float]]) -> Any:
        """Build a ``TFMessage`` of ``(parent, child, x, y, yaw)`` transforms (planar)."""
        return self.tf_static(
            ns,
            [
                (parent, child, (x, y, 0.0), (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)))
                for parent, child, x, y, yaw in transforms
            ],
        )

    def tf_static(
        self, ns: int, transforms: Sequence[tuple[str, str, Sequence[float], Sequence[float]]]
    ) -> Any:
        """Build a ``TFMessage`` of ``(parent, child, (x, y, z), (qx, qy, qz, qw))`` transforms.

        The message of ``/tf`` and ``/tf_static`` alike (see also :meth:`tf`).
        """
        t = self.t
        stamped = [
            t["geometry_msgs/msg/TransformStamped"](
                header=self.header(ns, parent),
                child_frame_id=child,
                transform=t["geometry_msgs/msg/Transform"](
                    translation=self._vector(*xyz),
                    rotation=t["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3]),
                ),
            )
            for parent, child, xyz, q in transforms
        ]
        return t[TF_MESSAGE](transforms=stamped)

    def nav_sat_fix(
        self, ns: int, lat: float, lon: float, alt: float = 0.0, status: int = 0, sigma: float = 0.0
    ) -> Any:
        """Build a ``NavSatFix`` (``status`` < 0: no fix); ``sigma`` > 0 gives a diagonal covariance."""
        cov = np.zeros(9)
        cov[[0, 4, 8]] = sigma**2
        return self.t[NAV_SAT_FIX](
            header=self.header(ns, "gps"),
            status=self.t["sensor_msgs/msg/NavSatStatus"](status=status, service=1),
            latitude=lat,
            longitude=lon,
            altitude=alt,
            position_covariance=cov,
            position_covariance_type=2 if sigma > 0 else 0,
        )

    def imu(self, ns: int, yaw: float | None, sigma: float = 0.01) -> Any:
        """Build a ``Imu`` with orientation ``yaw`` (None: no orientation, covariance[0] = -1)."""
        cov = np.zeros(9)
        cov[0], cov[8] = (-1.0, 0.0) if yaw is None else (sigma**2, sigma**2)
        return self.t[IMU](
            header=self.header(ns, "imu"),
            orientation=self.quaternion(0.0 if yaw is None else yaw),
            orientation_covariance=cov,
            angular_velocity=self._vector(),
            angular_velocity_covariance=np.zeros(9),
            linear_acceleration=self._vector(),
            linear_acceleration_covariance=np.zeros(9),
        )

    def image(self, ns: int, bgr: np.ndarray, frame: str = "camera_optical") -> Any:
        """Build a raw ``Image`` (``bgr8``) of an 8-bit BGR array."""
        h, w = bgr.shape[:2]
        return self.t[IMAGE](
            header=self.header(ns, frame),
            height=h,
            width=w,
            encoding="bgr8",
            is_bigendian=0,
            step=w * 3,
            data=np.ascontiguousarray(bgr, dtype=np.uint8).reshape(-1),
        )

    def compressed_image(
        self, ns: int, data: bytes, fmt: str = "jpeg", frame: str = "camera_optical"
    ) -> Any:
        """Build a ``CompressedImage`` holding already-encoded bytes."""
        return self.t[COMPRESSED_IMAGE](
            header=self.header(ns, frame),
            format=fmt,
            data=np.frombuffer(data, dtype=np.uint8),
        )

    def camera_info(self, ns: int, width: int, height: int, fx: float, cx: float, cy: float) -> Any:
        """Build a ``CameraInfo`` (square pixels, no distortion)."""
        k = np.array([fx, 0.0, cx, 0.0, fx, cy, 0.0, 0.0, 1.0])
        p = np.array([fx, 0.0, cx, 0.0, 0.0, fx, cy, 0.0, 0.0, 0.0, 1.0, 0.0])
        roi = self.t["sensor_msgs/msg/RegionOfInterest"](
            x_offset=0, y_offset=0, height=0, width=0, do_rectify=False
        )
        return self.t[CAMERA_INFO](
            header=self.header(ns, "camera"),
            height=height,
            width=width,
            distortion_model="plumb_bob",
            d=np.zeros(5),
            k=k,
            r=np.eye(3).reshape(-1),
            p=p,
            binning_x=0,
            binning_y=0,
            roi=roi,
        )


# Body axes (x forward, y left, z up) of the optical axes (x right, y down, z forward), as columns.
_OPTICAL = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


def _camera_records(m: MessageFactory, ns: int, camera: CameraConfig) -> list[Record]:
    """``CameraInfo`` and the ``/tf_static`` mounting (``base_footprint`` -> ``camera_optical``)."""
    body = Rotation.from_euler("ZY", [camera.mount_yaw, camera.mount_pitch]).as_matrix()
    q = Rotation.from_matrix(body @ _OPTICAL).as_quat()
    xyz = (camera.mount_x, camera.mount_y, camera.mount_height)
    info = m.camera_info(ns, camera.width, camera.height, camera.fx, camera.cx, camera.cy)
    return [
        ("/camera/camera_info", CAMERA_INFO, ns, info),
        (
            "/tf_static",
            TF_MESSAGE,
            ns,
            m.tf_static(ns, [("base_footprint", "camera_optical", xyz, q)]),
        ),
    ]


def log_records(
    log: WheelLog,
    wheel_radius: float,
    *,
    frames: FrameList | None = None,
    camera: CameraConfig | None = None,
    origin_s: int = 1_700_000_000,
) -> list[Record]:
    """Return a wheel log (and its frames) as the records a robot would write, in time order.

    Wheels: ``/joint_states`` (``left_wheel``, ``right_wheel``: speed /
    ``wheel_radius``, rad/s); poses: ``/pose`` (``PoseStamped``, rows with
    ``x, y, yaw``); frames: ``/camera/image/compressed`` (the files' bytes;
    JPEG or PNG); the camera: ``/camera/camera_info`` and ``/tf_static``.
    Stamps: ``origin_s`` + ``t``; receive time = stamp.
    """
    m = MessageFactory()
    ns = origin_s * 10**9 + np.round(log.t * 1e9).astype(np.int64)
    records: list[Record] = []
    for k in range(len(log)):
        omega = (log.v_l[k] / wheel_radius, log.v_r[k] / wheel_radius)
        records.append(
            (
                "/joint_states",
                JOINT_STATE,
                int(ns[k]),
                m.joint_state(int(ns[k]), ["left_wheel", "right_wheel"], omega),
            )
        )
        if log.has_pose[k]:
            records.append(
                (
                    "/pose",
                    POSE_STAMPED,
                    int(ns[k]),
                    m.pose_stamped(int(ns[k]), *map(float, log.pose[k])),
                )
            )
    if camera is not None:
        records += _camera_records(m, int(ns[0]), camera)
    for t, path in zip(frames.t if frames else [], frames.files if frames else [], strict=True):
        stamp = origin_s * 10**9 + int(round(float(t) * 1e9))
        fmt = "png" if path.suffix.lower() == ".png" else "jpeg"
        msg = m.compressed_image(stamp, path.read_bytes(), fmt)
        records.append(("/camera/image/compressed", COMPRESSED_IMAGE, stamp, msg))
    return sorted(records, key=lambda r: r[2])
