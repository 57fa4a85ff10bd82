"""Streaming reader of ROS bags: ROS 1 ``.bag``, ROS 2 bag folders (sqlite3, MCAP), ``.mcap``.

A thin layer over ``rosbags`` (pure Python, no ROS install): :func:`open_bag`
opens a recording and turns every failure into a one-line
:class:`~terrain_odom.errors.InputFileError`; :func:`topic_connections`
checks that a topic exists and has a type a role accepts;
:func:`stream_messages` yields the messages of some topics one at a time in
bag order (nothing is loaded whole); :func:`summarize_bag` lists every topic
with its type, count, rate, time span and roles, like ``rosbag info``.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rosbags.highlevel import AnyReader, AnyReaderError
from rosbags.interfaces import Connection
from rosbags.serde import SerdeError
from rosbags.typesys import Stores, get_typestore
from tqdm import tqdm

from terrain_odom.errors import InputFileError
from terrain_odom.io.bag.messages import ROLE_TYPES

__all__ = [
    "BagMessage",
    "BagSummary",
    "TopicSummary",
    "bag_kind",
    "open_bag",
    "roles_of",
    "short_type",
    "stream_messages",
    "summarize_bag",
    "topic_connections",
]

_EXPECTED = "expected a ROS 1 .bag file, a ROS 2 bag folder (metadata.yaml) or a .mcap file"


@dataclass(frozen=True)
class BagMessage:
    """One deserialised message: its topic, type, bag receive time (ns) and content."""

    topic: str
    msgtype: str
    receive_ns: int
    msg: Any


@dataclass(frozen=True)
class TopicSummary:
    """One topic of a bag: type, message count, receive-time span (ns) and roles here."""

    topic: str
    msgtype: str
    count: int
    start_ns: int | None
    end_ns: int | None
    roles: tuple[str, ...]

    @property
    def duration(self) -> float:
        """Time from the first to the last message, s (0 without messages)."""
        if self.start_ns is None or self.end_ns is None:
            return 0.0
        return (self.end_ns - self.start_ns) / 1e9

    @property
    def rate(self) -> float | None:
        """Mean message rate, Hz (None with fewer than two messages or no duration)."""
        return (self.count - 1) / self.duration if self.count > 1 and self.duration > 0 else None


@dataclass(frozen=True)
class BagSummary:
    """What ``inspect`` shows: the bag's kind, time span and topics."""

    path: str
    kind: str
    start_ns: int | None
    end_ns: int | None
    messages: int
    topics: list[TopicSummary] = field(default_factory=list)


def short_type(msgtype: str) -> str:
    """``sensor_msgs/msg/Imu`` -> ``sensor_msgs/Imu`` (the name as ROS 1 and users write it)."""
    return msgtype.replace("/msg/", "/")


def roles_of(msgtype: str) -> tuple[str, ...]:
    """Roles (``wheels``, ``pose``, ``heading``, ``images``, ``camera_info``) a type can play."""
    return tuple(role for role, types in ROLE_TYPES.items() if msgtype in types)


def bag_kind(path: str | os.PathLike[str]) -> str:
    """``ROS 1``, ``ROS 2 (sqlite3)``, ``ROS 2 (mcap)`` or ``MCAP`` from the path's form."""
    p = Path(path)
    if p.is_dir():
        storage = "mcap" if any(p.glob("*.mcap")) else "sqlite3"
        return f"ROS 2 ({storage})"
    return {".bag": "ROS 1", ".mcap": "MCAP", ".db3": "ROS 2 (sqlite3)"}.get(p.suffix, "unknown")


@contextmanager
def open_bag(path: str | os.PathLike[str]) -> Iterator[AnyReader]:
    """Open a bag for reading (a context manager yielding ``rosbags``' ``AnyReader``).

    Bags without message definitions (old ROS 2 sqlite3 bags) are read with
    the ROS 2 Humble types.

    Raises
    ------
    InputFileError
        If the path is missing or is not a bag ``rosbags`` can read.
    """
    p = Path(path)
    if not p.exists():
        raise InputFileError(f"{path}: no such file or folder; {_EXPECTED}")
    try:
        reader = AnyReader([p], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        reader.open()
    except (AnyReaderError, OSError, ValueError, KeyError) as exc:
        raise InputFileError(
            f"{path}: not a readable ROS bag ({_reason(exc)}); {_EXPECTED}"
        ) from None
    try:
        yield reader
    finally:
        reader.close()


def _reason(exc: BaseException) -> str:
    """One line of an exception's message."""
    text = " ".join(str(exc).split())
    return text or type(exc).__name__


def topic_connections(
    reader: AnyReader,
    path: str | os.PathLike[str],
    topic: str,
    option: str,
    accepted: Sequence[str],
) -> list[Connection]:
    """Return the connections of ``topic``, checked to exist, to have messages and an accepted type.

    Raises
    ------
    InputFileError
        Naming the option, the topic and what was expected (the topics that
        would do, for a missing one).
    """
    expected = ", ".join(short_type(t) for t in accepted)
    conns = [c for c in reader.connections if c.topic == topic]
    if not conns:
        fitting = sorted({c.topic for c in reader.connections if c.msgtype in accepted})
        hint = f"topics of a fitting type: {', '.join(fitting)}" if fitting else "none has one"
        raise InputFileError(
            f"{path}: {option} {topic}: no such topic in the bag (expected {expected}; {hint})"
        )
    wrong = [c.msgtype for c in conns if c.msgtype not in accepted]
    if wrong:
        raise InputFileError(
            f"{path}: {option} {topic}: type {short_type(wrong[0])}, expected {expected}"
        )
    if sum(c.msgcount for c in conns) == 0:
        raise InputFileError(f"{path}: {option} {topic}: the topic has no messages")
    return conns


def stream_messages(
    reader: AnyReader,
    path: str | os.PathLike[str],
    connections: Sequence[Connection],
    progress: bool | None = None,
) -> Iterator[BagMessage]:
    """Yield the messages of ``connections`` one at a time, in bag (receive-time) order.

    Parameters
    ----------
    progress : bool, optional
        Show a progress bar (messages); None shows it only on a terminal.

    Raises
    ------
    InputFileError
        If a topic's messages are not CDR (a ROS 2 or MCAP bag's JSON,
        Protobuf ...), or a message cannot be read or deserialised (a damaged bag).
    """
    for conn in connections:
        encoding = getattr(conn.ext, "serialization_format", "cdr")  # ROS 1: its own
        if encoding != "cdr":
            raise InputFileError(
                f"{path}: topic {conn.topic}: messages encoded as {encoding!r}; terrain-odom "
                "reads ROS 1 and CDR (ROS 2) messages"
            )
    total = sum(c.msgcount for c in connections)
    bar = tqdm(total=total, unit="msg", disable=None if progress is None else not progress)
    try:
        for conn, receive_ns, raw in reader.messages(connections=connections):
            try:
                msg = reader.deserialize(raw, conn.msgtype)
            except (AnyReaderError, SerdeError, ValueError, IndexError) as exc:
                raise InputFileError(
                    f"{path}: topic {conn.topic}: a {short_type(conn.msgtype)} message at "
                    f"{receive_ns / 1e9:.6f} s cannot be read ({_reason(exc)})"
                ) from None
            bar.update()
            yield BagMessage(conn.topic, conn.msgtype, receive_ns, msg)
    finally:
        bar.close()


def summarize_bag(path: str | os.PathLike[str], progress: bool | None = None) -> BagSummary:
    """List every topic of a bag: type, count, receive-time span and roles.

    The span of each topic needs one pass over the messages (not
    deserialised); the bag is streamed, never loaded.
    """
    with open_bag(path) as reader:
        spans: dict[str, list[int]] = {}
        total = reader.message_count
        bar = tqdm(total=total, unit="msg", disable=None if progress is None else not progress)
        with bar:
            for conn, receive_ns, _ in reader.messages():
                span = spans.setdefault(conn.topic, [receive_ns, receive_ns])
                span[0], span[1] = min(span[0], receive_ns), max(span[1], receive_ns)
                bar.update()
        topics = []
        for name in sorted({c.topic for c in reader.connections}):
            conns = [c for c in reader.connections if c.topic == name]
            msgtype = conns[0].msgtype
            seen = spans.get(name)
            topics.append(
                TopicSummary(
                    topic=name,
                    msgtype=msgtype,
                    count=sum(c.msgcount for c in conns),
                    start_ns=seen[0] if seen else None,
                    end_ns=seen[1] if seen else None,
                    roles=roles_of(msgtype),
                )
            )
        starts = [s[0] for s in spans.values()]
        ends = [s[1] for s in spans.values()]
        return BagSummary(
            path=str(path),
            kind=bag_kind(path),
            start_ns=min(starts) if starts else None,
            end_ns=max(ends) if ends else None,
            messages=sum(t.count for t in topics),
            topics=topics,
        )
