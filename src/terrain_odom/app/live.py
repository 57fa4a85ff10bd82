"""Odometry on a live robot: messages in as they arrive, estimates out (``terrain-odom-ros``'s core).

Middleware-free: the ROS node (:mod:`terrain_odom.ros.node`) hands every
message it receives to :meth:`LiveOdometry.message` with its role
(``wheels``, ``pose``, ``heading``, ``images``) and type, and publishes each
:class:`LiveOutput`. Messages are converted by the streams ``import`` uses
(:mod:`~terrain_odom.io.bag.streams`: one conversion for a bag's messages
and a live one's) and fed to
:class:`~terrain_odom.estimation.online.OnlineOdometry` as the rows of the
log ``import`` would write (:mod:`~terrain_odom.io.bag.log`'s rules), so a
recording played into the node gives ``terrain-odom run``'s estimates.

Ordering policy (docs/ros.md):

- a message is held in a time-ordered buffer until a message stamped
  ``delay`` s later has arrived (or no message has arrived for ``delay`` s
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

import dataclasses
import heapq
import math
import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from terrain_odom.app.calibration import check_heading_bias
from terrain_odom.app.frames import one_thread
from terrain_odom.config import load_config
from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.estimation._kernel_switch import compile_kernels
from terrain_odom.estimation.online import OnlineOdometry
from terrain_odom.io.bag.frames import frame_rgb
from terrain_odom.io.bag.log import time_origin_ns
from terrain_odom.io.bag.messages import ROLE_TYPES, TF_MESSAGE, message_type
from terrain_odom.io.bag.reader import BagMessage, short_type
from terrain_odom.io.bag.streams import HeadingStream, PoseStream, StampRule, WheelStream
from terrain_odom.kinematics.models import twist_icr, twist_icr_jacobian
from terrain_odom.records import Sighting, TerrainChange

if TYPE_CHECKING:
    from terrain_odom.vision.frame_classifier import FrameClassification, FrameClassifier

__all__ = [
    "FRAME_POLICIES",
    "LiveOdometry",
    "LiveOptions",
    "LiveOutput",
    "LiveTopics",
    "build_live",
    "twist_with_covariance",
]

FRAME_POLICIES = ("async", "sync")
MAX_PENDING_FRAMES = 3
"""Frames waiting for the classifier beyond which a new one is skipped (counted)."""
ROLES = ("wheels", "pose", "heading", "images")
_RANK = {"wheels": 0, "pose": 1, "heading": 2, "images": 3}  # order within one microsecond
_NS_PER_US = 1000


@dataclass(frozen=True)
class LiveTopics:
    """Where the messages of each role come from and how to read them (``import``'s options).

    ``wheels_msgtype`` is needed up front only to check the geometry:
    ``JointState`` needs ``wheel_radius``, a body twist ``track_width``.
    """

    wheels: str
    pose: str | None = None
    heading: str | None = None
    images: str | None = None
    left_joints: tuple[str, ...] = ("*left*",)
    right_joints: tuple[str, ...] = ("*right*",)
    pose_frames: tuple[str, str] | None = None
    gps_origin: tuple[float, float, float] | None = None
    stamps: str = "header"


@dataclass(frozen=True)
class LiveOptions:
    """The ordering policy (module docstring).

    Attributes
    ----------
    delay : float
        s: how long a message waits for earlier-stamped ones (stamp time).
    max_gap : float
        s: a longer gap between wheel messages starts a new segment.
    jump_back : float
        s: a wheel message this much before the latest row restarts the clock.
    frames : {"async", "sync"}
        Classify frames off the wheel path (default), or wait for each.
    idle : float
        s of wall time without a message after which :meth:`LiveOdometry.poll`
        releases what is buffered (a paused stream's last messages).
    """

    delay: float = 0.1
    max_gap: float = 0.5
    jump_back: float = 1.0
    frames: str = "async"
    idle: float = 0.25

    def __post_init__(self) -> None:
        for name in ("delay", "max_gap", "jump_back", "idle"):
            value = getattr(self, name)
            bound = ">=" if name == "delay" else ">"
            if not (0.0 <= value < math.inf) or (name != "delay" and value == 0.0):
                flag = name.replace("_", "-")
                raise ConfigError(f"--{flag} must be finite and {bound} 0 s, got {value}")
        if self.frames not in FRAME_POLICIES:
            raise ConfigError(f"frames must be one of {', '.join(FRAME_POLICIES)}")


@dataclass(frozen=True)
class LiveOutput:
    """The estimate after one row: what the node publishes.

    Attributes
    ----------
    stamp_ns : int
        The row's stamp (ns, the messages' clock).
    t : float
        The row's time on the log clock (s since the time origin, as ``run``'s).
    names : tuple of str
        Names of ``state`` and ``std`` (:attr:`OnlineOdometry.names`).
    state, std : ndarray
        Estimate and standard deviations.
    twist, twist_cov : ndarray, shape (3,), (3, 3)
        Body twist ``v_x, v_y, omega`` (m/s, m/s, rad/s) of the held wheel
        speeds and the current ICRs, and its covariance from theirs.
    terrain : str
        Terrain applied to the filter (``""`` before any).
    changes : tuple of TerrainChange
        Terrain changes applied since the previous output.
    """

    stamp_ns: int
    t: float
    names: tuple[str, ...]
    state: np.ndarray
    std: np.ndarray
    twist: np.ndarray
    twist_cov: np.ndarray
    terrain: str
    changes: tuple[TerrainChange, ...] = ()


def twist_with_covariance(
    v_l: float, v_r: float, names: tuple[str, ...], state: np.ndarray, std: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Body twist of the ICR model and its covariance, the ICR errors taken independent.

    ``Sigma_twist = J diag(std_icr^2) J^T`` with ``J`` the Jacobian of
    :func:`~terrain_odom.kinematics.models.twist_icr` in ``y_l, y_r, x_icr,
    alpha`` (``alpha`` 1 with zero variance when not estimated).

    Examples
    --------
    >>> names = ("x", "y", "yaw", "y_l", "y_r", "x_icr")
    >>> twist, cov = twist_with_covariance(1.0, 1.0, names, np.r_[0, 0, 0, .5, -.5, 0.],
    ...                                    np.r_[0, 0, 0, .1, .1, .1])
    >>> twist.tolist(), bool(np.all(cov == 0.0))  # straight ahead: no ICR error matters
    ([1.0, -0.0, 0.0], True)
    """
    index = [names.index(n) for n in ("y_l", "y_r", "x_icr")]
    params = [float(state[i]) for i in index]
    sigmas = [float(std[i]) for i in index]
    if "alpha" in names:
        params.append(float(state[names.index("alpha")]))
        sigmas.append(float(std[names.index("alpha")]))
    else:
        params.append(1.0)
        sigmas.append(0.0)
    twist = np.array(twist_icr(v_l, v_r, *params), dtype=float)
    jac = np.asarray(twist_icr_jacobian(v_l, v_r, *params), dtype=float)
    return twist, (jac * np.square(sigmas)) @ jac.T


@dataclass(order=True)
class _Event:
    key: int  # microseconds
    rank: int
    seq: int
    role: str = field(compare=False)
    value: Any = field(compare=False)
    stamp_ns: int = field(compare=False)


@dataclass
class _Frame:
    t: float
    message: BagMessage  # an Image or CompressedImage, decoded by the worker
    speeds: tuple[float, float]
    params: np.ndarray
    odometer: float


class _FrameWorker:
    """Classify frames on a thread of their own; results come back in order."""

    def __init__(self, classifier: FrameClassifier) -> None:
        self.classifier = classifier
        self.todo: queue.Queue[_Frame | None] = queue.Queue()
        self.done: queue.Queue[tuple[_Frame, FrameClassification | Exception]] = queue.Queue()
        self.pending = 0
        self.thread = threading.Thread(target=self._loop, name="terrain-odom-frames", daemon=True)
        self.thread.start()

    def _loop(self) -> None:
        with one_thread():  # a frame's small KNN query and OpenCV calls: no thread pools
            self._classify_all()

    def _classify_all(self) -> None:
        while (frame := self.todo.get()) is not None:
            try:
                msg = frame.message
                image = frame_rgb(msg.msg, msg.msgtype, f"--image-topic {msg.topic}")
                result: FrameClassification | Exception = self.classifier.classify(
                    frame.t, image, *frame.speeds, frame.params
                )
            except Exception as exc:  # a frame the classifier refuses: counted, not fatal
                result = exc
            self.done.put((frame, result))

    def submit(self, frame: _Frame) -> None:
        self.pending += 1
        self.todo.put(frame)

    def results(self, wait: bool) -> list[tuple[_Frame, FrameClassification | Exception]]:
        """Return the classifications done (all of them, waiting, with ``wait``)."""
        out = []
        while self.pending:
            try:
                item = self.done.get(block=wait)
            except queue.Empty:
                break
            self.pending -= 1
            out.append(item)
        return out

    def stop(self) -> None:
        self.todo.put(None)
        self.thread.join(timeout=5.0)


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
        delay = odometry.config.time.pose_delay
        if delay == "auto":
            raise ConfigError(
                "time.pose_delay: auto is estimated from a whole log; give the node seconds"
            )
        self._wheel_shift_ns = int(round(float(delay) * 1e9))
        self._streams = self._make_streams(topics, odometry)
        self._types: dict[str, str] = {}  # role -> message type of its first message
        self._worker = _FrameWorker(frame_classifier) if frame_classifier is not None else None
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
    @staticmethod
    def _make_streams(topics: LiveTopics, odometry: OnlineOdometry) -> dict[str, Any]:
        robot, stamps = odometry.config.robot, StampRule(topics.stamps)
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
        bad input: it is dropped and counted (:attr:`dropped`).
        """
        kind = message_type(msgtype)
        if kind not in ROLE_TYPES[role]:
            accepted = ", ".join(short_type(t) for t in ROLE_TYPES[role])
            self._drop(f"{role}: a message of type {short_type(kind)} (expected {accepted})")
            return
        if kind == TF_MESSAGE and self.topics.pose_frames is None:
            self._drop("pose: a tf2_msgs/TFMessage topic needs --pose-frames PARENT CHILD")
            return
        first = self._types.setdefault(role, kind)
        if kind != first:
            self._drop(f"{role}: a {short_type(kind)} after {short_type(first)} messages")
            return
        wrapped = BagMessage(getattr(self.topics, role) or role, kind, receive_ns, msg)
        try:
            events = self._convert(role, wrapped)
        except (InputFileError, ValueError, AttributeError, IndexError, TypeError) as exc:
            self._drop(f"{role}: unusable message ({str(exc).split(': ', 1)[-1]})")
            return
        with self._lock:
            self._arrived = self.clock()
            for stamp, value in events:
                self._push(role, stamp, value)
            self._release(self._watermark())

    def _convert(self, role: str, message: BagMessage) -> list[tuple[int, Any]]:
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
        self._worker.submit(_Frame(t, message, self._speeds, np.array(params), odo.odometer))
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


def build_live(
    config: str | Path | None,
    topics: LiveTopics,
    options: LiveOptions | None = None,
    *,
    classifier: str | Path | None = None,
    estimator: str = "icr-ekf",
    robot: dict[str, float | None] | None = None,
    **callbacks: Any,
) -> LiveOdometry:
    """Build the live odometry of a configuration file (the built-in defaults for None).

    ``classifier``: a terrain classifier file for the ``images`` role's
    frames (the packaged default model when ``topics.images`` is given
    without one); ``robot``: ``track_width``, ``wheel_radius`` overriding the
    configuration's (``import``'s ``--track-width``, ``--wheel-radius``);
    ``callbacks``: the keyword arguments of :class:`LiveOdometry`.

    Raises
    ------
    ConfigError, InputFileError
        A bad configuration, options, or classifier file (one line).
    """
    cfg = load_config(config)
    given = {k: v for k, v in (robot or {}).items() if v is not None}
    for name, value in given.items():
        if not 0.0 < value < math.inf:
            raise ConfigError(f"--{name.replace('_', '-')} must be finite and > 0 m, got {value}")
    if given:
        cfg = dataclasses.replace(cfg, robot=dataclasses.replace(cfg.robot, **given))
    if topics.stamps not in ("header", "receive"):
        raise ConfigError(f"--stamps must be header or receive, got {topics.stamps!r}")
    check_heading_bias(cfg, topics.pose is not None, "no --pose-topic")
    frames = None
    if topics.images is not None:
        from terrain_odom.io.classifier_file import default_model, load_classifier
        from terrain_odom.vision.camera import GroundCamera
        from terrain_odom.vision.frame_classifier import FrameClassifier

        model = load_classifier(classifier if classifier is not None else default_model())
        frames = FrameClassifier(model, GroundCamera(cfg.camera), cfg.roi)
    odometry = OnlineOdometry(cfg, estimator=estimator)  # type: ignore[arg-type]
    _warm_up(cfg, estimator, frames)
    return LiveOdometry(odometry, topics, options, frame_classifier=frames, **callbacks)


def _warm_up(cfg: Any, estimator: str, frames: FrameClassifier | None) -> None:
    """Make the first calls now: numba's kernels (~1.5 s, holding the GIL), lazy imports.

    Else they fall on the first messages (or, compiled after a number of
    calls, on the Nth), stalling the wheels.
    """
    compile_kernels()
    warm = OnlineOdometry(cfg, estimator=estimator)  # type: ignore[arg-type]
    for k in range(4):
        warm.wheels(0.02 * k, 0.5, 0.6)
        warm.pose(0.02 * k, 0.01 * k, 0.0, 0.0)
    state, std = warm.estimate()
    twist_with_covariance(0.5, 0.6, warm.names, state, std)
    if frames is not None:
        camera = frames.camera
        noise = np.random.default_rng(0).integers(0, 256, (camera.height, camera.width, 3))
        params = [state[warm.names.index(n)] for n in ("y_l", "y_r", "x_icr")]
        frames.classify(0.0, noise.astype(np.uint8), 0.5, 0.6, np.array(params))
