"""Messages in as they arrive, estimates out: the ordering policy of ``terrain-odom-ros``'s core.

The ROS node (:mod:`terrain_odom.ros.node`) hands every message it
receives to :meth:`LiveOdometry.message` with its role (``wheels``,
``pose``, ``heading``, ``images``) and type, and publishes each
:class:`~terrain_odom.app.live.output.LiveOutput`. Messages are converted by
:mod:`~terrain_odom.app.live.convert` (``import``'s streams) and fed to
:class:`~terrain_odom.estimation.online.OnlineOdometry` as the rows of the
log ``import`` would write (:mod:`~terrain_odom.io.bag.log`'s rules), so a
recording played into the node gives ``terrain-odom run``'s estimates.

Ordering policy (docs/ros.md):

- a message is held in a time-ordered buffer until a message stamped
  ``delay`` s later has arrived (or no message has arrived for ``idle`` s
  of wall time: :meth:`LiveOdometry.poll`), then released in stamp order;
  messages whose stamps share a microsecond form one row, as in the log;
- a message stamped before the latest row released is late: dropped and
  counted (an EKF cannot go back; a pose or heading stamped at that row is
  still fused there, a wheel message is not); so is anything before the first wheel
  message, and a pose inside a gap of the wheel messages longer than
  ``max_gap`` (which starts a new segment);
- a wheel message stamped ``jump_back`` s or more before the latest row
  (a looping ``rosbag play``, a restarted simulation) restarts the clock:
  the buffer is dropped (counted) and a new segment starts at it;
- non-finite values, unusable messages and topics of a wrong type are
  dropped and counted by reason; each reason is reported once
  (``on_warning``), the counts are in :attr:`LiveOdometry.dropped`.

Camera frames are decoded and classified on a worker thread, off the wheel
messages' path: a frame released in time order is
handed to the worker with the held wheel speeds, the current ICRs and the
odometer; its sighting is fed at the first row after the classification is
done, placed where the frame saw it (``ahead`` less the distance travelled
since: :attr:`~terrain_odom.estimation.online.OnlineOdometry.odometer`); a
frame arriving while :data:`MAX_PENDING_FRAMES` wait is skipped (counted).
``frames="sync"`` waits for each classification instead (a replay that
must equal ``run`` in every terrain mode, at the cost of stalling).
"""

from __future__ import annotations

import heapq
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from terrain_odom.app.live.convert import MessageConverter
from terrain_odom.app.live.frame_worker import MAX_PENDING_FRAMES, FrameJob, FrameWorker
from terrain_odom.app.live.options import ROLES, LiveOptions, LiveTopics
from terrain_odom.app.live.output import LiveOutput, twist_with_covariance
from terrain_odom.estimation.online import OnlineOdometry
from terrain_odom.io.bag.log import time_origin_ns
from terrain_odom.io.bag.reader import BagMessage
from terrain_odom.records import Sighting

if TYPE_CHECKING:
    from terrain_odom.vision.frame_classifier import FrameClassifier

__all__ = ["LiveOdometry"]

_RANK = {role: rank for rank, role in enumerate(ROLES)}  # order within one microsecond
_NS_PER_US = 1000


@dataclass(order=True)
class _Event:
    key: int  # microseconds
    rank: int
    seq: int
    role: str = field(compare=False)
    value: Any = field(compare=False)
    stamp_ns: int = field(compare=False)


class LiveOdometry:
    """Messages in, :class:`LiveOutput` out (module docstring for the policy).

    Thread-safe: the node's callbacks run on several threads; rows are
    processed under one lock, frames classified on a worker thread.

    Parameters
    ----------
    odometry : OnlineOdometry
        A fresh estimator (its ``config`` gives the robot geometry and
        ``time.pose_delay``).
    topics : LiveTopics
    options : LiveOptions
    frame_classifier : FrameClassifier, optional
        Classifies the ``images`` role's frames (none: frames are counted and dropped).
    on_output : callable
        Called with each row's :class:`LiveOutput` (in the processing thread).
    on_warning : callable
        Called once per drop reason, with a one-line message.
    clock : callable
        Wall clock, s (for :meth:`poll`).
    """

    def __init__(
        self,
        odometry: OnlineOdometry,
        topics: LiveTopics,
        options: LiveOptions | None = None,
        *,
        frame_classifier: FrameClassifier | None = None,
        on_output: Callable[[LiveOutput], None] = lambda out: None,
        on_warning: Callable[[str], None] = lambda text: None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.odometry = odometry
        self.topics = topics
        self.options = options or LiveOptions()
        self.on_output, self.on_warning, self.clock = on_output, on_warning, clock
        self._converter = MessageConverter(odometry.config, topics, self._drop)
        self._worker = FrameWorker(frame_classifier) if frame_classifier is not None else None
        self._lock = threading.RLock()
        self._changes_seen = 0
        self._heap: list[_Event] = []
        self._seq = 0
        self._newest_key: int | None = None
        self._arrived = clock()
        self._reset_clock()
        self.dropped: dict[str, int] = {}
        self.counts = {role: 0 for role in ROLES} | {"rows": 0, "frames_classified": 0}

    # ------------------------------------------------------------ set-up
    def _reset_clock(self, keep_origin: bool = False) -> None:
        """Forget the time line (latest row, wheel sample; the origin unless ``keep_origin``)."""
        if not keep_origin:
            self._origin_us: int | None = None
        self._released: int | None = None  # key of the latest row released, us
        self._wheel_key: int | None = None  # key of the latest wheel row, us
        self._row_key: int | None = None  # key of the latest row fed, us
        self._speeds = (math.nan, math.nan)
        self._restart = True

    # ------------------------------------------------------------ input
    def message(self, role: str, msgtype: str, msg: Any, receive_ns: int = 0) -> None:
        """Take one message of ``role`` (``wheels``, ``pose``, ``heading``, ``images``).

        ``msgtype``: ``pkg/Name`` or ``pkg/msg/Name``; ``receive_ns``: the
        receive time (the stamp with ``stamps="receive"``). Never raises on
        a bad message: it is dropped and counted (:attr:`dropped`).

        Raises
        ------
        ValueError
            ``role`` is none of the four (a caller's mistake, not a message's).
        """
        if role not in _RANK:
            raise ValueError(f"unknown role {role!r}: expected one of {', '.join(_RANK)}")
        events = self._converter.convert(role, msgtype, msg, receive_ns)
        if events is None:
            return
        with self._lock:
            self._arrived = self.clock()
            for stamp, value in events:
                self._push(role, stamp, value)
            self._release(self._watermark())

    def _push(self, role: str, stamp_ns: int, value: Any) -> None:
        """Queue one converted value, or drop it (non-finite, late) or restart the clock."""
        if role == "pose" and not any(map(math.isfinite, value)):
            self._drop("pose: no finite component")  # a NaN component alone: not measured
            return
        if role == "heading" and not math.isfinite(value):  # import's stream drops NaN wheels
            self._drop("heading: non-finite value")
            return
        key = (stamp_ns + _NS_PER_US // 2) // _NS_PER_US
        if self._released is not None and key <= self._released:
            back = (self._released - key) / 1e6
            if role == "wheels" and back >= self.options.jump_back:
                self._jump_back(back)
            elif key < self._released or role == "wheels":  # at the latest row: still fused
                self._drop(f"{role}: late (stamped before a row already processed)")
                return
        self._seq += 1
        heapq.heappush(self._heap, _Event(key, _RANK[role], self._seq, role, value, stamp_ns))
        self._newest_key = key if self._newest_key is None else max(self._newest_key, key)

    def _jump_back(self, back: float) -> None:
        """Time went back: drop what is buffered, start a new segment at the new time."""
        self.dropped["time jumped back (restarts)"] = (
            self.dropped.get("time jumped back (restarts)", 0) + 1
        )
        self.on_warning(
            f"time jumped back {back:.3f} s: a new segment starts (a looping rosbag play?)"
        )
        for event in self._heap:
            self._count(f"{event.role}: dropped at a jump back in time")
        self._heap.clear()
        self._newest_key = None
        self._reset_clock(keep_origin=True)

    def _watermark(self) -> int | None:
        """Key up to which rows are released (``delay`` before the newest stamp)."""
        if self._newest_key is None:
            return None
        return self._newest_key - int(round(self.options.delay * 1e6))

    def poll(self) -> None:
        """Release everything buffered if no message arrived for ``idle`` s (wall); apply frames.

        Call it periodically (the node does, at 20 Hz), so a pause of the
        streams does not hold the last messages back.
        """
        with self._lock:
            if self.clock() - self._arrived >= self.options.idle and self._heap:
                self._release(None)
            self._apply_frames(wait=False)

    def flush(self) -> None:
        """Release everything buffered and wait for the frames being classified (at the end)."""
        with self._lock:
            self._release(None)
            self._apply_frames(wait=True)

    def close(self) -> None:
        """Flush, then stop the frame worker."""
        self.flush()
        if self._worker is not None:
            self._worker.stop()

    # ------------------------------------------------------------ processing
    def _release(self, upto: int | None) -> None:
        """Process the buffered rows with key <= ``upto`` (all for None), in time order."""
        heap = self._heap
        while heap and (upto is None or heap[0].key <= upto):
            key = heap[0].key
            group = []
            while heap and heap[0].key == key:
                group.append(heapq.heappop(heap))
            self._apply_frames(wait=False)
            self._row(key, group)

    def _row(self, key: int, group: list[_Event]) -> None:
        """Process the events of one microsecond: a log row, then its frames."""
        values: dict[str, Any] = {}
        frames = []
        for event in group:
            self.counts[event.role] += 1
            if event.role == "images":
                frames.append(event)
                continue
            if event.role in values:
                self._count(f"{event.role}: duplicate stamp (the last one kept)")
            values[event.role] = event.value
        self._released = key
        if values and self._rows(key, values, group[0].stamp_ns):
            self._emit(key, group[0].stamp_ns)
        for frame in frames:
            self._frame(key, frame.value)

    def _rows(self, key: int, values: dict[str, Any], stamp_ns: int) -> bool:
        """Feed one row to the odometry; return whether it was fed (else dropped, counted)."""
        odo = self.odometry
        wheels = values.get("wheels")
        if key == self._row_key:  # a pose at the latest row's stamp, arrived after it
            pose = self._pose(values)
            if pose is not None:
                odo.pose((key - (self._origin_us or 0)) / 1e6, *pose)
            return True
        if self._wheel_key is None and wheels is None:
            for role in values:
                self._drop(f"{role}: before the first wheel message")
            return False
        if self._origin_us is None:
            self._origin_us = time_origin_ns(np.array([key * _NS_PER_US])) // _NS_PER_US
        t = (key - self._origin_us) / 1e6
        max_gap_us = int(round(self.options.max_gap * 1e6))
        if wheels is not None:
            gap = self._wheel_key is not None and key - self._wheel_key > max_gap_us
            odo.wheels(t, *wheels, new_segment=self._restart or gap)
            self._restart, self._wheel_key, self._speeds = False, key, wheels
        elif self._wheel_key is not None and key - self._wheel_key > max_gap_us:
            for role in values:
                self._drop(f"{role}: in a gap of the wheel messages (longer than max_gap)")
            return False
        else:
            odo.wheels(t, *self._speeds)
        pose = self._pose(values)
        if pose is not None:
            odo.pose(t, *pose)
        self._row_key = key
        return True

    def _pose(self, values: dict[str, Any]) -> tuple[float, float, float] | None:
        """Return the row's measured ``x, y, yaw``: a pose, a heading, or a GPS position and heading."""
        pose, heading = values.get("pose"), values.get("heading")
        if heading is None:
            return pose
        if pose is None:
            return (math.nan, math.nan, heading)
        if math.isnan(pose[2]):
            return (pose[0], pose[1], heading)
        self._count("heading: on the row of a pose with yaw (the pose's kept)")
        return pose

    def _emit(self, key: int, stamp_ns: int) -> None:
        odo = self.odometry
        self.counts["rows"] += 1
        state, std = odo.estimate()
        twist, cov = twist_with_covariance(*self._speeds, odo.names, state, std)
        changes = tuple(odo.changes[self._changes_seen :])
        self._changes_seen = len(odo.changes)
        assert self._origin_us is not None
        self.on_output(
            LiveOutput(
                stamp_ns=stamp_ns,
                t=(key - self._origin_us) / 1e6,
                names=odo.names,
                state=state,
                std=std,
                twist=twist,
                twist_cov=cov,
                terrain=odo.current_terrain,
                changes=changes,
            )
        )

    def _frame(self, key: int, message: BagMessage) -> None:
        """Hand a released frame to the worker (with the state it is classified in)."""
        odo = self.odometry
        if self._worker is None:
            self._drop("images: no terrain classifier (--classifier)")
            return
        if self._wheel_key is None or self._origin_us is None:
            self._drop("images: before the first wheel message")
            return
        if self._worker.pending >= MAX_PENDING_FRAMES:
            self._drop("images: the classifier is behind (frames skipped to keep up)")
            return
        state, _ = odo.estimate()
        names = odo.names
        params = [state[names.index(n)] for n in ("y_l", "y_r", "x_icr", "alpha") if n in names]
        t = (key - self._origin_us) / 1e6
        self._worker.submit(FrameJob(t, message, self._speeds, np.array(params), odo.odometer))
        if self.options.frames == "sync":
            self._apply_frames(wait=True)

    def _apply_frames(self, wait: bool) -> None:
        """Feed the sightings of the frames classified so far (waiting for all with ``wait``)."""
        if self._worker is None:
            return
        odo = self.odometry
        for frame, result in self._worker.results(wait):
            if isinstance(result, Exception):
                self._drop(f"images: not classified ({str(result).split(': ', 1)[-1]})")
                continue
            self.counts["frames_classified"] += 1
            if result.sighting is None or odo.t is None:
                continue
            moved = odo.odometer - frame.odometer
            sighting = Sighting(result.sighting.label, result.sighting.ahead - moved)
            odo.sighting(odo.t, sighting)

    # ------------------------------------------------------------ counts
    def reject(self, role: str, reason: str) -> None:
        """Count a message of ``role`` the caller could not use (e.g. not deserialisable)."""
        self._drop(f"{role}: {reason}")

    def _count(self, reason: str) -> None:
        self.dropped[reason] = self.dropped.get(reason, 0) + 1

    def _drop(self, reason: str) -> None:
        """Count a dropped message; report a reason the first time it occurs."""
        with self._lock:
            first = reason not in self.dropped
            self._count(reason)
        if first:
            self.on_warning(f"dropped: {reason} (counted; reported once)")

    def status(self) -> dict[str, dict[str, int]]:
        """Return copies of :attr:`counts` and :attr:`dropped` (safe while messages come in)."""
        with self._lock:
            return {"counts": dict(self.counts), "dropped": dict(self.dropped)}

    def summary(self) -> str:
        """One line: messages taken per role, rows, and drops by reason."""
        taken = ", ".join(f"{n} {role}" for role, n in self.counts.items() if n)
        drops = "; ".join(f"{n} {reason}" for reason, n in sorted(self.dropped.items()))
        return f"{taken or 'no messages'}; dropped: {drops or 'none'}"
