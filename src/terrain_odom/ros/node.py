"""``terrain-odom-ros``: the ROS 1 node, a thin ``rospy`` layer over :mod:`terrain_odom.app.live`.

Subscribes to the topics named with ``import``'s flags (any message class:
the type is read from each connection, so a topic of a wrong type is
counted, not fatal), hands every message to
:class:`~terrain_odom.app.live.odometry.LiveOdometry` and publishes each row's
estimate (docs/ros.md: topics, parameters, the layout of ``icr``):

- ``odometry`` (``nav_msgs/Odometry``), the TF ``odom -> base_link`` with
  ``--publish-tf``;
- ``terrain`` (``std_msgs/String``, latched), ``terrain_changes``
  (``std_msgs/String``, one line a change);
- ``icr`` (``std_msgs/Float64MultiArray``: ``y_l, y_r, x_icr, alpha`` then
  their standard deviations);
- ``~status`` (``std_msgs/String``, latched, JSON: messages taken and
  dropped by reason), every second and at shutdown.

``rospy`` and the message packages are imported when the node starts
(Debian's ``python3-rospy`` ...: docs/ros.md), so this module imports
without ROS.
"""

from __future__ import annotations

import argparse
import json
import math
import queue
import sys
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

from terrain_odom.app.live.build import build_live
from terrain_odom.app.live.odometry import LiveOdometry
from terrain_odom.app.live.options import FRAME_POLICIES, ROLES, LiveOptions, LiveTopics
from terrain_odom.app.live.output import LiveOutput
from terrain_odom.cli.bag_import import add_bag_topic_options
from terrain_odom.cli.options import add_config_option
from terrain_odom.errors import TerrainOdomError

__all__ = ["build_parser", "main"]

EXIT_USAGE = 2
UNKNOWN_VARIANCE = 1e6
"""Variance published for what a planar estimate does not know (z, roll, pitch): m^2, rad^2."""


def build_parser() -> argparse.ArgumentParser:
    """Return the node's argument parser (``import``'s topic options plus the node's own)."""
    p = argparse.ArgumentParser(
        prog="terrain-odom-ros",
        description="Terrain-adaptive odometry as a ROS 1 node (docs/ros.md).",
    )
    add_config_option(p, "the configuration run uses (robot, filter, camera; default built-in)")
    add_bag_topic_options(p, wheels_required=True)
    p.add_argument("--image-topic", help="sensor_msgs/Image or CompressedImage: camera frames")
    p.add_argument("--classifier", metavar="NPZ", help="terrain classifier (default: packaged)")
    p.add_argument("--estimator", choices=("icr-ekf", "slip-ekf"), default="icr-ekf")
    p.add_argument("--delay", type=float, default=0.1, help="s: reorder buffer (default 0.1)")
    p.add_argument(
        "--idle",
        type=float,
        default=0.25,
        help="s (wall): release the buffer after this long without a message (default 0.25)",
    )
    p.add_argument(
        "--jump-back",
        type=float,
        default=1.0,
        help="s: a wheel stamp this far back restarts the clock (default 1)",
    )
    p.add_argument("--frames", choices=FRAME_POLICIES, default="async", help="frame policy")
    p.add_argument("--odom-frame", default="odom", help="frame of the pose (default odom)")
    p.add_argument("--base-frame", default="base_link", help="robot frame (default base_link)")
    p.add_argument("--publish-tf", action="store_true", help="broadcast odom -> base_link")
    p.add_argument(
        "--stale",
        type=float,
        default=1.0,
        help="s: warn when no wheel message came for this long (default 1)",
    )
    return p


class _Publishers:
    """The node's publishers and the conversion of a :class:`LiveOutput` into messages."""

    def __init__(self, args: argparse.Namespace) -> None:
        import rospy
        from nav_msgs.msg import Odometry
        from std_msgs.msg import Float64MultiArray, String

        self.args = args
        self.odometry = rospy.Publisher("odometry", Odometry, queue_size=50)
        self.icr = rospy.Publisher("icr", Float64MultiArray, queue_size=50)
        self.terrain = rospy.Publisher("terrain", String, queue_size=5, latch=True)
        self.changes = rospy.Publisher("terrain_changes", String, queue_size=20)
        self.status = rospy.Publisher("~status", String, queue_size=2, latch=True)
        self.tf = None
        if args.publish_tf:
            import tf2_ros

            self.tf = tf2_ros.TransformBroadcaster()
        self._terrain: str | None = None

    def publish(self, out: LiveOutput) -> None:
        """Publish one row's estimate."""
        import genpy
        from std_msgs.msg import String

        stamp = genpy.Time(out.stamp_ns // 1_000_000_000, out.stamp_ns % 1_000_000_000)
        value = dict(zip(out.names, out.state.tolist(), strict=True))
        std = dict(zip(out.names, out.std.tolist(), strict=True))
        self.odometry.publish(self._odometry(out, stamp, value, std))
        if self.tf is not None:
            self.tf.sendTransform(self._transform(stamp, value))
        self.icr.publish(_icr_message(value, std))
        if out.terrain and out.terrain != self._terrain:  # none before the first label
            self._terrain = out.terrain
            self.terrain.publish(String(data=out.terrain))
        for change in out.changes:
            how = "restored" if change.restored else ("reset" if change.reset else "no reset")
            text = f"t={change.t:.6f} {change.previous} -> {change.label} ({how})"
            self.changes.publish(String(data=text))

    def _odometry(self, out: LiveOutput, stamp: Any, value: dict, std: dict) -> Any:
        from nav_msgs.msg import Odometry

        msg = Odometry()
        msg.header.stamp = stamp
        msg.header.frame_id = self.args.odom_frame
        msg.child_frame_id = self.args.base_frame
        pose = msg.pose.pose
        pose.position.x, pose.position.y = value["x"], value["y"]
        pose.orientation.z = math.sin(0.5 * value["yaw"])
        pose.orientation.w = math.cos(0.5 * value["yaw"])
        msg.pose.covariance = _covariance_6x6([std["x"] ** 2, std["y"] ** 2, std["yaw"] ** 2], None)
        twist = msg.twist.twist
        twist.linear.x, twist.linear.y, twist.angular.z = out.twist.tolist()
        msg.twist.covariance = _covariance_6x6(None, out.twist_cov)
        return msg

    def _transform(self, stamp: Any, value: dict) -> Any:
        from geometry_msgs.msg import TransformStamped

        tr = TransformStamped()
        tr.header.stamp = stamp
        tr.header.frame_id = self.args.odom_frame
        tr.child_frame_id = self.args.base_frame
        tr.transform.translation.x, tr.transform.translation.y = value["x"], value["y"]
        tr.transform.rotation.z = math.sin(0.5 * value["yaw"])
        tr.transform.rotation.w = math.cos(0.5 * value["yaw"])
        return tr


def _covariance_6x6(planar: list[float] | None, twist_cov: Any) -> list[float]:
    """Row-major 6x6 covariance (x, y, z, roll, pitch, yaw) of a planar estimate.

    ``planar``: variances of x, y, yaw (diagonal); ``twist_cov``: the 3x3
    covariance of ``v_x, v_y, omega``. z, roll and pitch get
    :data:`UNKNOWN_VARIANCE`.
    """
    cov = [0.0] * 36
    for i in (2, 3, 4):
        cov[i * 7] = UNKNOWN_VARIANCE
    axes = (0, 1, 5)
    if planar is not None:
        for axis, var in zip(axes, planar, strict=True):
            cov[axis * 7] = var
    else:
        for a, row in zip(axes, twist_cov.tolist(), strict=True):
            for b, var in zip(axes, row, strict=True):
                cov[a * 6 + b] = var
    return cov


def _icr_message(value: dict, std: dict) -> Any:
    """``Float64MultiArray`` [y_l, y_r, x_icr, alpha, std_y_l, std_y_r, std_x_icr, std_alpha]."""
    from std_msgs.msg import Float64MultiArray, MultiArrayDimension

    names = ("y_l", "y_r", "x_icr", "alpha")
    data = [value.get(n, 1.0) for n in names] + [std.get(n, 0.0) for n in names]
    msg = Float64MultiArray(data=data)
    msg.layout.dim = [
        MultiArrayDimension(label="value,std", size=2, stride=8),
        MultiArrayDimension(label=",".join(names), size=4, stride=4),
    ]
    return msg


class _Subscriber:
    """One topic of a role, any message class: the raw message queued for the pump, at once.

    ``rospy`` calls each topic's callback on a thread of its own; queueing
    there and converting on one thread (:class:`_Pump`) keeps a busy machine
    from delaying one topic behind the others (the ordering sees arrival order).
    """

    def __init__(self, topic: str, role: str, pump: _Pump) -> None:
        import rospy

        self.role, self.pump = role, pump
        self.sub = rospy.Subscriber(topic, rospy.AnyMsg, self.callback, queue_size=1000)

    def callback(self, raw: Any) -> None:
        import rospy

        self.pump.inbox.put((self.role, raw, rospy.get_rostime().to_nsec()))


class _Pump:
    """Deserialise the queued messages (by the type their connection names) and feed them."""

    def __init__(self, live: LiveOdometry, watch: _Watch) -> None:
        self.live, self.watch = live, watch
        self.inbox: queue.Queue[tuple[str, Any, int] | None] = queue.Queue()
        self.classes: dict[str, Any] = {}
        self.thread = threading.Thread(target=self._loop, name="terrain-odom-pump", daemon=True)

    def _loop(self) -> None:
        while (item := self.inbox.get()) is not None:
            try:
                self.feed(*item)
            except Exception as exc:  # never let one message stop the pump: count it
                self.live.reject(item[0], f"an error on it ({type(exc).__name__}: {exc})")

    def feed(self, role: str, raw: Any, receive_ns: int) -> None:
        """Deserialise one raw message and hand it to the live odometry (or count why not)."""
        from roslib.message import get_message_class

        header = raw._connection_header
        kind = header["type"]
        if kind not in self.classes:
            self.classes[kind] = get_message_class(kind)
        cls = self.classes[kind]
        if cls is None:
            self.live.message(role, kind, None)  # an unknown type: counted as wrong
            return
        md5 = header.get("md5sum")
        if md5 not in (None, "*", cls._md5sum):
            self.live.reject(role, f"a {kind} of another definition (md5sum {md5})")
            return
        try:
            msg = cls().deserialize(raw._buff)
        except Exception as exc:  # genpy.DeserializationError: counted, the node goes on
            self.live.reject(role, f"a {kind} that does not deserialise ({exc})")
            return
        if role == "wheels":
            self.watch.wheel()
        self.live.message(role, kind, msg, receive_ns)

    def stop(self) -> None:
        """Feed what is queued, then stop."""
        self.inbox.put(None)
        self.thread.join(timeout=10.0)


class _Watch:
    """Wall-clock chores on a thread: release paused buffers, warn on silence, publish status."""

    def __init__(self, live: LiveOdometry, pubs: _Publishers, stale: float) -> None:
        self.live, self.pubs, self.stale = live, pubs, stale
        self.pending: Callable[[], bool] = lambda: False  # messages queued, not yet converted
        self.last_wheel: float | None = None
        self.silent = False
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._loop, name="terrain-odom-watch", daemon=True)

    def wheel(self) -> None:
        self.last_wheel = time.monotonic()
        self.silent = False

    def _loop(self) -> None:
        import rospy

        ticks = 0
        while not self.stop.wait(0.05):
            if not self.pending():  # queued messages: the node is behind, the streams go on
                self.live.poll()
            ticks += 1
            since = None if self.last_wheel is None else time.monotonic() - self.last_wheel
            if since is not None and since > self.stale and not self.silent:
                self.silent = True
                rospy.logwarn(f"terrain-odom: no wheel messages for {since:.1f} s")
            if ticks % 20 == 0:
                self.publish_status()

    def publish_status(self) -> None:
        from std_msgs.msg import String

        status = json.dumps(self.live.status(), sort_keys=True)
        self.pubs.status.publish(String(data=status))


def _topics(args: argparse.Namespace) -> LiveTopics:
    return LiveTopics(
        wheels=args.wheels_topic,
        pose=args.pose_topic,
        heading=args.heading_topic,
        images=args.image_topic,
        left_joints=tuple(args.left_joints),
        right_joints=tuple(args.right_joints),
        pose_frames=tuple(args.pose_frames) if args.pose_frames else None,
        gps_origin=tuple(args.gps_origin) if args.gps_origin else None,
        stamps=args.stamps,
    )


def run_node(args: argparse.Namespace) -> LiveOdometry:
    """Start the node, spin until shutdown (SIGINT, ``rosnode kill``); return the live odometry."""
    import rospy

    holder: dict[str, _Publishers] = {}
    live = build_live(  # first: bad options and files stop the node before it joins the master
        args.config,
        _topics(args),
        LiveOptions(args.delay, args.max_gap, args.jump_back, args.frames, args.idle),
        classifier_path=args.classifier,
        estimator=args.estimator,
        robot={"track_width": args.track_width, "wheel_radius": args.wheel_radius},
        on_output=lambda out: holder["pubs"].publish(out),
        on_warning=lambda text: rospy.logwarn(f"terrain-odom: {text}"),
    )
    rospy.init_node("terrain_odom")
    pubs = holder["pubs"] = _Publishers(args)
    watch = _Watch(live, pubs, args.stale)
    pump = _Pump(live, watch)
    watch.pending = lambda: not pump.inbox.empty()
    subscribers = [
        _Subscriber(topic, role, pump)
        for role in ROLES
        if (topic := getattr(live.topics, role)) is not None
    ]
    pump.thread.start()
    watch.thread.start()
    robot = live.odometry.config.robot
    source = "--config" if args.config else "the built-in defaults: give --config"
    rospy.loginfo(
        f"terrain-odom: robot track_width {robot.track_width:g} m, wheel_radius "
        f"{robot.wheel_radius:g} m ({source} or --track-width/--wheel-radius)"
    )
    rospy.loginfo(f"terrain-odom: listening to {', '.join(s.sub.name for s in subscribers)}")
    rospy.spin()
    for sub in subscribers:
        sub.sub.unregister()
    pump.stop()
    watch.stop.set()
    watch.thread.join(timeout=2.0)
    live.close()
    watch.publish_status()
    print(f"terrain-odom-ros: {live.summary()}", file=sys.stderr, flush=True)
    return live


def main(argv: Sequence[str] | None = None) -> int:
    """Run the node; returns the exit code (2 with one line on bad options or input)."""
    try:
        import rospy
    except ImportError:
        print(
            "terrain-odom-ros: error: rospy is not importable: install ROS 1 (docs/ros.md: "
            "apt-get install python3-rospy ...) and run from a venv made with "
            "--system-site-packages from Debian's /usr/bin/python3",
            file=sys.stderr,
        )
        return EXIT_USAGE
    given = sys.argv[1:] if argv is None else list(argv)
    args = build_parser().parse_args(rospy.myargv(["terrain-odom-ros", *given])[1:])
    try:
        run_node(args)
    except TerrainOdomError as exc:
        print(f"terrain-odom-ros: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
