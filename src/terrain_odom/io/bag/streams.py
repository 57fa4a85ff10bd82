"""Collect the streams of a bag import, message by message (:class:`BagStreams`: one import's).

:class:`WheelStream`, :class:`PoseStream` and :class:`HeadingStream` each
take the messages of one topic (:meth:`add`) and keep only the few numbers
per message the wheel log needs (a stamp and two or three floats, in
compact arrays: 24-32 bytes a message), so a long bag is read in one pass
at small memory; :meth:`rows` returns them as
:class:`~terrain_odom.io.bag.log.StampedRows`. Each raises a one-line
:class:`~terrain_odom.errors.InputFileError` naming the topic on a message
it cannot use (a ``JointState`` without velocities or without the joints
asked for, an ``Imu`` without orientation on every message, a
``NavSatFix`` topic without any fix, ``/tf`` without the frames asked for).
"""

from __future__ import annotations

from array import array
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from terrain_odom.errors import InputFileError
from terrain_odom.io.bag.log import StampedRows
from terrain_odom.io.bag.messages import (
    JOINT_STATE,
    NAV_SAT_FIX,
    ODOMETRY,
    POSE_COV_STAMPED,
    TF_MESSAGE,
    Intrinsics,
    enu_from_geodetic,
    fix_status,
    imu_yaw,
    joint_speeds,
    match_joints,
    planar_pose,
    pose_sigmas,
    stamp_ns,
    tf_pose,
    track_speeds,
)
from terrain_odom.io.bag.reader import BagMessage

__all__ = [
    "BagStreams",
    "HeadingStream",
    "PoseStream",
    "StampRule",
    "WheelStream",
    "median_sigma",
    "outlying_stamps",
    "MAX_STAMP_SKEW",
]


@dataclass(frozen=True)
class StampRule:
    """Which time a message gets: its header stamp (``header``) or the bag's (``receive``)."""

    kind: str = "header"

    def of(self, message: BagMessage, header: Any | None = None) -> int | None:
        """Return the stamp (ns) of ``message`` (``header``: another header than the message's own).

        None for a header stamp of 0 (never set by the sender).
        """
        if self.kind == "receive":
            return message.receive_ns
        ns = stamp_ns((header if header is not None else message.msg.header).stamp)
        return ns or None


MAX_STAMP_SKEW = 3600.0
"""s: a header stamp further than this from the others' (against the bag's receive times) is wrong."""
_OUTLYING = f"header stamp over {MAX_STAMP_SKEW:g} s away from the others' (a wrong clock or stamp)"


MAX_GROUND_SPEED = 30.0
"""m/s: no ground robot drives faster (as the plausibility checks' ``max_speed``)."""
FIX_SLACK = 1000.0
"""m: the distance a fix may lie from the others' median beyond a drive at :data:`MAX_GROUND_SPEED`."""
_FAR_FIX = (
    "GPS fix further from the others than a ground robot drives in the recording "
    "(latitude/longitude 0/0?)"
)


_ZERO_FIX = "GPS fix at latitude/longitude 0/0 (a receiver's placeholder)"


def outlying_stamps(stamp_ns: np.ndarray, receive_ns: np.ndarray) -> np.ndarray:
    """Mask of the stamps that lie over :data:`MAX_STAMP_SKEW` from the rest, judged by receive time.

    A message's skew is its stamp minus its receive time; the topic's
    median skew is its clock's offset (0, or a simulated clock's); a stamp
    whose skew differs from it by more than an hour belongs to no recording
    of this bag (e.g. 2**31 - 1 s). The mask is empty for ``--stamps
    receive`` (no skew).

    Examples
    --------
    >>> hour = 3_600 * 10**9
    >>> outlying_stamps(np.array([5, 6, 7 + 2 * hour, 8]), np.array([1, 2, 3, 4])).tolist()
    [False, False, True, False]
    """
    if not stamp_ns.size:
        return np.zeros(0, dtype=bool)
    skew = (stamp_ns - receive_ns).astype(np.float64)
    return np.asarray(np.abs(skew - np.median(skew)) > MAX_STAMP_SKEW * 1e9)


def median_sigma(values: Sequence[float]) -> float | None:
    """Median of the finite positive standard deviations, or None if there are none.

    Examples
    --------
    >>> median_sigma([0.1, float("nan"), 0.3, 0.2])
    0.2
    """
    good = [v for v in values if np.isfinite(v) and v > 0]
    return float(np.median(good)) if good else None


@dataclass
class _Stream:
    """Stamps and values of one topic, with counts of what was skipped.

    ``sensor_frame``: the frame whose pose or orientation the topic measures
    (for the sensor's mounting from ``/tf_static``), if its messages name one.
    """

    where: str
    stamps: StampRule
    stamps_kept: array[int] = field(default_factory=lambda: array("q"))
    values_kept: array[float] = field(default_factory=lambda: array("d"))
    receive_kept: array[int] = field(default_factory=lambda: array("q"))
    skipped: dict[str, int] = field(default_factory=dict)
    sensor_frame: str | None = None

    def _name_frame(self, frame: str) -> None:
        """Remember the sensor frame of the first message that names one."""
        if self.sensor_frame is None and frame.lstrip("/"):
            self.sensor_frame = frame.lstrip("/")

    def _keep(
        self, message: BagMessage, value: float | Sequence[float], header: Any | None = None
    ) -> None:
        """Keep a value (a float, or a fixed number of floats per message) at the message's stamp."""
        stamp = self.stamps.of(message, header)
        if stamp is None:
            self._skip("header stamp 0 (unset; --stamps receive uses the bag's time)")
            return
        self.stamps_kept.append(stamp)
        self.receive_kept.append(message.receive_ns)
        if isinstance(value, float):
            self.values_kept.append(value)
        else:
            self.values_kept.extend(value)

    def _skip(self, reason: str) -> None:
        self.skipped[reason] = self.skipped.get(reason, 0) + 1

    def rows(self, width: int) -> StampedRows:
        """Return the stamps and values kept; values of shape (N, width) (or (N,) if 0).

        Messages whose stamp is an outlier (:func:`outlying_stamps`) are left
        out and counted as skipped.
        """
        n = len(self.stamps_kept)
        values = np.array(self.values_kept, dtype=float).reshape((n, width) if width else (n,))
        stamps = np.array(self.stamps_kept, dtype=np.int64)
        odd = outlying_stamps(stamps, np.array(self.receive_kept, dtype=np.int64))
        if odd.any():
            self.skipped[_OUTLYING] = int(odd.sum())  # set, not added: rows() may be asked again
            stamps, values = stamps[~odd], values[~odd]
        return StampedRows(stamps, values)

    def take(self, width: int) -> StampedRows:
        """Return the stamps and values kept since the last call, and forget them.

        For a live stream (message by message): what :meth:`add` converted,
        at flat memory.
        """
        rows = self.rows(width)
        del self.stamps_kept[:]
        del self.values_kept[:]
        return rows


@dataclass
class WheelStream(_Stream):
    """Track speeds from ``JointState`` (joint velocities) or a body twist (Odometry, TwistStamped).

    ``wheel_radius`` (m) and the joint patterns serve ``JointState``;
    ``track_width`` (m) serves the twists.
    """

    wheel_radius: float | None = None
    track_width: float | None = None
    left: tuple[str, ...] = ("*left*",)
    right: tuple[str, ...] = ("*right*",)
    _joints: dict[tuple[str, ...], tuple[list[int], list[int]]] = field(default_factory=dict)

    def add(self, message: BagMessage) -> None:
        """Convert and keep one wheel message."""
        msg = message.msg
        if message.msgtype == JOINT_STATE:
            with np.errstate(invalid="ignore", over="ignore"):  # judged below
                speeds = self._joint_state(msg)
        else:
            twist = msg.twist.twist if message.msgtype == ODOMETRY else msg.twist
            assert self.track_width is not None  # Python floats: NaN, inf pass silently
            speeds = track_speeds(float(twist.linear.x), float(twist.angular.z), self.track_width)
        if not np.isfinite(speeds).all():  # a driver's NaN or inf: dropped, counted
            self._skip("wheel speed not finite (NaN or inf)")
            return
        self._keep(message, speeds)

    def _joint_state(self, msg: Any) -> tuple[float, float]:
        names = tuple(msg.name)
        if len(msg.velocity) != len(names) or not names:
            raise InputFileError(
                f"{self.where}: a JointState without velocities ({len(msg.velocity)} for "
                f"{len(names)} joints); expected a velocity per joint, rad/s"
            )
        if names not in self._joints:
            left, right = match_joints(names, self.left), match_joints(names, self.right)
            if not left or not right or set(left) & set(right):
                raise InputFileError(
                    f"{self.where}: joints {list(names)} do not split into left "
                    f"{list(self.left)} and right {list(self.right)} (--left-joints, "
                    "--right-joints: shell patterns, each joint on one side only)"
                )
            self._joints[names] = (left, right)
        assert self.wheel_radius is not None
        return joint_speeds(msg.velocity, *self._joints[names], self.wheel_radius)

    def wheel_rows(self) -> StampedRows:
        """Stamps and ``v_l, v_r`` (m/s), shape (N, 2)."""
        return self.rows(2)


@dataclass
class PoseStream(_Stream):
    """Planar poses from Odometry, PoseStamped, PoseWithCovarianceStamped, ``/tf`` or NavSatFix.

    ``frames`` (parent, child) select the ``/tf`` transform; ``origin``
    (lat, lon deg, alt m) is the ENU origin of a NavSatFix topic (default
    the first valid fix in time). Standard deviations of the message
    covariances are kept for the configuration. ``sensor_frame`` is the
    frame whose pose is measured (for its mounting on the robot): a
    NavSatFix's ``frame_id`` (the antenna), an Odometry's
    ``child_frame_id``, the ``/tf`` pose's child; None for a PoseStamped
    (its ``frame_id`` is the world frame; it names no body frame).
    """

    frames: tuple[str, str] | None = None
    origin: tuple[float, float, float] | None = None
    sigmas: list[tuple[float, float, float]] = field(default_factory=list)
    frames_seen: set[tuple[str, str]] = field(default_factory=set)
    origin_used: tuple[float, float, float] | None = None

    def add(self, message: BagMessage) -> None:
        """Convert and keep one pose message (or the matching transforms of a ``/tf`` message)."""
        msg, kind = message.msg, message.msgtype
        if kind == TF_MESSAGE:
            self._transforms(message)
        elif kind == NAV_SAT_FIX:
            self._name_frame(msg.header.frame_id)
            self._fix(message)
        elif kind in (ODOMETRY, POSE_COV_STAMPED):
            if kind == ODOMETRY:
                self._name_frame(msg.child_frame_id)
            self._keep(message, planar_pose(msg.pose.pose))
            self.sigmas.append(pose_sigmas(msg.pose.covariance))
        else:
            self._keep(message, planar_pose(msg.pose))

    def _transforms(self, message: BagMessage) -> None:
        assert self.frames is not None
        for tr in message.msg.transforms:
            pair = (tr.header.frame_id.lstrip("/"), tr.child_frame_id.lstrip("/"))
            self.frames_seen.add(pair)
            if pair == self.frames:
                self.sensor_frame = self.frames[1]
                self._keep(message, tf_pose(tr.transform), tr.header)

    def _fix(self, message: BagMessage) -> None:
        """Keep a fix with a solution; a NaN altitude (unknown, legal in ROS) is kept as NaN."""
        msg = message.msg
        position = (float(msg.latitude), float(msg.longitude), float(msg.altitude))
        if fix_status(msg) < 0 or not (abs(position[0]) <= 90.0 and abs(position[1]) <= 180.0):
            self._skip("GPS fix without a solution (status < 0 or NaN)")
            return
        if np.isinf(position[2]):
            position = (position[0], position[1], np.nan)
        self._keep(message, position)
        if int(msg.position_covariance_type) > 0:
            cov = msg.position_covariance
            self.sigmas.append((float(np.sqrt(cov[0])), float(np.sqrt(cov[4])), np.nan))

    def pose_rows(self, topic_type: str) -> StampedRows:
        """Stamps and ``x, y, yaw``, shape (N, 3); GPS fixes as east, north, NaN.

        Raises
        ------
        InputFileError
            If ``/tf`` had no transform between the frames asked for, or a
            NavSatFix topic no fix with a solution.
        """
        if topic_type == TF_MESSAGE and not self.stamps_kept:
            assert self.frames is not None
            seen = ", ".join(f"{p} -> {c}" for p, c in sorted(self.frames_seen)) or "none"
            raise InputFileError(
                f"{self.where}: no transform {self.frames[0]} -> {self.frames[1]} "
                f"(--pose-frames PARENT CHILD; transforms seen: {seen})"
            )
        if topic_type != NAV_SAT_FIX:
            return self.rows(3)
        if not self.stamps_kept:
            raise InputFileError(
                f"{self.where}: a NavSatFix topic without fixes (every message has status < 0 "
                "or NaN position); expected at least one fix with a solution"
            )
        return self._enu(self._near(self.rows(3)))

    def _near(self, geo: StampedRows) -> StampedRows:
        """Drop (and count) fixes further from the others' median than a ground robot drives.

        A robot at :data:`MAX_GROUND_SPEED` over the recording's span, plus
        :data:`FIX_SLACK`: a fix beyond is a receiver's placeholder
        (latitude 0, longitude 0) or a wrong solution.
        """
        if not len(geo):
            return geo
        centre = (float(np.median(geo.values[:, 0])), float(np.median(geo.values[:, 1])), 0.0)
        flat = np.zeros(len(geo))
        distance = np.hypot(
            *enu_from_geodetic(geo.values[:, 0], geo.values[:, 1], flat, centre)[:, :2].T
        )
        span = float(geo.stamp_ns.max() - geo.stamp_ns.min()) * 1e-9
        far = distance > MAX_GROUND_SPEED * span + FIX_SLACK
        if not far.any() or far.all():
            return geo
        self.skipped[_FAR_FIX] = int(far.sum())  # set, not added: rows may be asked again
        return StampedRows(geo.stamp_ns[~far], geo.values[~far])

    def take_poses(self, topic_type: str) -> StampedRows:
        """Return the poses converted since the last call (as :meth:`pose_rows`), and forget them.

        A live stream: GPS fixes in the east-north frame of ``origin``, else
        of the first fix taken.
        """
        self.sigmas.clear()
        rows = self.take(3)
        if topic_type != NAV_SAT_FIX:
            return rows
        zero = (rows.values[:, 0] == 0.0) & (rows.values[:, 1] == 0.0)
        if zero.any():  # no median to judge by here: never an origin at a receiver's placeholder
            self.skipped[_ZERO_FIX] = self.skipped.get(_ZERO_FIX, 0) + int(zero.sum())
            rows = StampedRows(rows.stamp_ns[~zero], rows.values[~zero])
        return self._enu(rows) if len(rows) else rows

    def _enu(self, geo: StampedRows) -> StampedRows:
        """East, north, NaN of fixes (lat, lon deg, alt m) in the frame of ``origin_used``.

        ``origin_used`` is set on the first call: ``origin``, else the first
        fix in time among ``geo``.
        """
        if self.origin_used is None:
            first = int(np.argmin(geo.stamp_ns))
            self.origin_used = self.origin or tuple(float(v) for v in geo.values[first])  # type: ignore[assignment]
        assert self.origin_used is not None
        if not np.isfinite(self.origin_used[2]):  # altitude unknown: the first one known, or 0
            known = geo.values[np.isfinite(geo.values[:, 2]), 2]
            self.origin_used = (*self.origin_used[:2], float(known[0]) if known.size else 0.0)
        alt = np.where(np.isfinite(geo.values[:, 2]), geo.values[:, 2], self.origin_used[2])
        enu = enu_from_geodetic(geo.values[:, 0], geo.values[:, 1], alt, self.origin_used)
        values = np.column_stack([enu[:, 0], enu[:, 1], np.full(len(geo), np.nan)])
        return StampedRows(geo.stamp_ns, values)

    def sigma(self) -> dict[str, float]:
        """Median standard deviations of x, y, yaw over the message covariances (known ones)."""
        columns = list(zip(*self.sigmas, strict=True)) if self.sigmas else [(), (), ()]
        found = {k: median_sigma(c) for k, c in zip(("x", "y", "yaw"), columns, strict=True)}
        return {k: v for k, v in found.items() if v is not None}


@dataclass
class HeadingStream(_Stream):
    """Yaw from ``Imu`` orientations (messages without an orientation are skipped and counted).

    ``sensor_frame``: the first message's ``frame_id``, the IMU frame whose
    orientation the message holds (REP 145).
    """

    sigmas: list[float] = field(default_factory=list)

    def add(self, message: BagMessage) -> None:
        """Convert and keep one Imu message."""
        self._name_frame(message.msg.header.frame_id)
        yaw = imu_yaw(message.msg)
        if yaw is None:
            self._skip("Imu without orientation")
            return
        self._keep(message, yaw)
        self.sigmas.append(float(np.sqrt(max(float(message.msg.orientation_covariance[8]), 0.0))))

    def take_headings(self) -> StampedRows:
        """Return the yaws converted since the last call, and forget them (a live stream)."""
        self.sigmas.clear()
        return self.take(0)

    def heading_rows(self) -> StampedRows:
        """Stamps and yaw (rad), shape (N,).

        Raises
        ------
        InputFileError
            If no message had an orientation.
        """
        if not self.stamps_kept and "Imu without orientation" in self.skipped:
            raise InputFileError(
                f"{self.where}: an Imu topic without orientation (orientation_covariance[0] "
                "= -1 on every message); expected an orientation for the heading"
            )
        return self.rows(0)

    def sigma(self) -> float | None:
        """Median yaw standard deviation of the orientation covariances, if known."""
        return median_sigma(self.sigmas)


@dataclass
class BagStreams:
    """The streams of one import and the topics they read (filled message by message).

    Attributes
    ----------
    wheels, poses, headings : WheelStream, PoseStream or None, HeadingStream or None
    types : dict of str to str
        The topics read: their message types.
    bag : str
    images : list of (int, str)
        Each frame written: its stamp (ns) and file (``frames/NNNNNN.jpg``).
    camera : Intrinsics or None
        The first CameraInfo's; ``camera_topic`` its topic.
    static : dict of (str, str) to ndarray
        ``/tf_static``'s transforms (4x4) by (parent, child) frame.
    image_frame : str or None
        The first image's ``frame_id``.
    images_unstamped : int
        Images skipped for a zero header stamp.
    """

    wheels: WheelStream
    poses: PoseStream | None
    headings: HeadingStream | None
    types: dict[str, str]
    bag: str
    images: list[tuple[int, str]] = field(default_factory=list)
    camera: Intrinsics | None = None
    static: dict[tuple[str, str], np.ndarray] = field(default_factory=dict)
    image_frame: str | None = None
    images_unstamped: int = 0
    camera_topic: str | None = None
