"""A live message of a role in, stamped values out: ``import``'s streams, one conversion for both.

Messages are converted by the streams ``import`` uses
(:mod:`~terrain_odom.io.bag.streams`: one conversion for a bag's messages
and a live one's), so a recording played into the node gives the rows of
the log ``import`` would write. A message of a wrong type, a TF topic
without its frames, or an unusable message gives no values: it is dropped
and counted by reason (the ``drop`` callback).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from terrain_odom.app.live.options import LiveTopics
from terrain_odom.config import Config
from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.io.bag.messages import ROLE_TYPES, TF_MESSAGE, message_type
from terrain_odom.io.bag.reader import BagMessage, short_type
from terrain_odom.io.bag.streams import HeadingStream, PoseStream, StampRule, WheelStream

__all__ = ["MessageConverter"]


class MessageConverter:
    """Convert the messages of each role with ``import``'s streams.

    Parameters
    ----------
    config : Config
        The robot geometry (``robot``) and the wheels' ``time.pose_delay`` (s).
    topics : LiveTopics
    drop : callable
        Called with the reason of each message (or value) dropped.

    Raises
    ------
    ConfigError
        ``time.pose_delay: auto`` (estimated from a whole log, not live).
    """

    def __init__(self, config: Config, topics: LiveTopics, drop: Callable[[str], None]) -> None:
        delay = config.time.pose_delay
        if delay == "auto":
            raise ConfigError(
                "time.pose_delay: auto is estimated from a whole log; give the node seconds"
            )
        self.topics, self._drop = topics, drop
        self._wheel_shift_ns = int(round(float(delay) * 1e9))
        self._streams = self._make_streams(topics, config)
        self._types: dict[str, str] = {}  # role -> message type of its first message

    @staticmethod
    def _make_streams(topics: LiveTopics, config: Config) -> dict[str, Any]:
        robot, stamps = config.robot, StampRule(topics.stamps)
        wheels = WheelStream(
            f"--wheels-topic {topics.wheels}",
            stamps,
            wheel_radius=robot.wheel_radius,
            track_width=robot.track_width,
            left=topics.left_joints,
            right=topics.right_joints,
        )
        pose = PoseStream(
            f"--pose-topic {topics.pose}",
            stamps,
            frames=topics.pose_frames,
            origin=topics.gps_origin,
        )
        heading = HeadingStream(f"--heading-topic {topics.heading}", stamps)
        return {"wheels": wheels, "pose": pose, "heading": heading}

    def convert(
        self, role: str, msgtype: str, msg: Any, receive_ns: int
    ) -> list[tuple[int, Any]] | None:
        """Return the ``(stamp ns, value)`` a message gives; None if it is dropped (counted).

        ``msgtype``: ``pkg/Name`` or ``pkg/msg/Name``; ``receive_ns``: the
        receive time (the stamp with ``stamps="receive"``). Values: wheel
        speeds ``(v_l, v_r)`` m/s stamped with ``time.pose_delay`` added, a
        pose ``(x, y, yaw)``, a heading ``yaw`` (rad), an image's message.
        """
        kind = message_type(msgtype)
        if kind not in ROLE_TYPES[role]:
            accepted = ", ".join(short_type(t) for t in ROLE_TYPES[role])
            self._drop(f"{role}: a message of type {short_type(kind)} (expected {accepted})")
            return None
        if kind == TF_MESSAGE and self.topics.pose_frames is None:
            self._drop("pose: a tf2_msgs/TFMessage topic needs --pose-frames PARENT CHILD")
            return None
        first = self._types.setdefault(role, kind)
        if kind != first:
            self._drop(f"{role}: a {short_type(kind)} after {short_type(first)} messages")
            return None
        wrapped = BagMessage(getattr(self.topics, role) or role, kind, receive_ns, msg)
        try:
            return self._stamped(role, wrapped)
        except (InputFileError, ValueError, AttributeError, IndexError, TypeError) as exc:
            self._drop(f"{role}: unusable message ({str(exc).split(': ', 1)[-1]})")
            return None

    def _stamped(self, role: str, message: BagMessage) -> list[tuple[int, Any]]:
        """Return the ``(stamp ns, value)`` a message gives (none if skipped: counted)."""
        if role == "images":
            stamp = StampRule(self.topics.stamps).of(message)
            if stamp is None:
                self._drop("images: header stamp 0 (unset)")
                return []
            return [(stamp, message)]  # decoded by the frame worker, off the wheel path
        stream = self._streams[role]
        skipped = dict(stream.skipped)
        stream.add(message)
        for reason, n in stream.skipped.items():
            if n > skipped.get(reason, 0):
                self._drop(f"{role}: {reason}")
        if role == "wheels":
            rows = stream.take(2)
            return [
                (int(s) + self._wheel_shift_ns, (float(v[0]), float(v[1])))
                for s, v in zip(rows.stamp_ns, rows.values, strict=True)
            ]
        if role == "pose":
            rows = stream.take_poses(message.msgtype)
            return [
                (int(s), tuple(map(float, v)))
                for s, v in zip(rows.stamp_ns, rows.values, strict=True)
            ]
        rows = stream.take_headings()
        return [(int(s), float(v)) for s, v in zip(rows.stamp_ns, rows.values, strict=True)]
