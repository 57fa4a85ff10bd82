"""Latency and sustained rate of the live node's core (``terrain-odom-ros`` without the transport).

Messages as a robot sends them (``rosbags`` objects, built by
:class:`~terrain_odom.io.bag.writer.MessageFactory`): ``JointState`` wheels
at 100 Hz, ``Imu`` headings at 50 Hz, ``NavSatFix`` fixes at 5 Hz and
``CompressedImage`` frames at 10 Hz (the shipped simulated run's 320x240
JPEGs, classified by the packaged model on the worker thread), fed to
:class:`~terrain_odom.app.live.odometry.LiveOdometry` on a schedule in real time,
the process pinned to one core. Printed:

- per wheel message, the latency from the message's arrival
  (:meth:`~terrain_odom.app.live.odometry.LiveOdometry.message`) to its row's
  output (what the node publishes as ``odometry``): median, p99, max, with
  the camera on and, as the baseline measured in the same run, off
  (reorder delay 0: stamps in order; a delay ``d`` adds ``d`` by design);
- the sustained rate: the same mix fed as fast as it goes (wheel messages
  per second, with the other topics in proportion and every frame classified).

Targets (issue 25): median <= 1 ms, p99 <= 5 ms, camera on. The machine
load (``os.getloadavg``) is printed: on a shared machine the tail moves.

Usage::

    python bench/ros_latency.py [--seconds 20]
"""

from __future__ import annotations

import argparse
import math
import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from terrain_odom.app.live.build import build_live
from terrain_odom.app.live.options import LiveOptions, LiveTopics
from terrain_odom.app.live.output import LiveOutput
from terrain_odom.io.bag.messages import COMPRESSED_IMAGE, IMU, JOINT_STATE, NAV_SAT_FIX
from terrain_odom.io.bag.writer import MessageFactory

REPO = Path(__file__).resolve().parents[1]
SAMPLE = REPO / "sample_images" / "chen2023"
RATES = {"wheels": 100.0, "heading": 50.0, "pose": 5.0, "images": 10.0}
TYPES = {"wheels": JOINT_STATE, "heading": IMU, "pose": NAV_SAT_FIX, "images": COMPRESSED_IMAGE}
LAT0, LON0 = 45.0, -73.0


def schedule(seconds: float, camera: bool) -> list[tuple[float, str, Any]]:
    """Return ``(send time s, role, message)`` of a robot driving a 10-m circle at 1 m/s."""
    m = MessageFactory()
    frames = sorted((SAMPLE / "frames").glob("*.jpg"))[:40]
    jpegs = [f.read_bytes() for f in frames]
    base = 1_700_000_000 * 10**9
    out = []
    for role, rate in RATES.items():
        if role == "images" and not camera:
            continue
        for k in range(int(seconds * rate)):
            t = k / rate
            ns = base + int(round(t * 1e9))
            yaw = t / 10.0
            if role == "wheels":
                msg = m.joint_state(ns, ["left_wheel", "right_wheel"], (9.5, 10.5))
            elif role == "heading":
                msg = m.imu(ns, math.remainder(yaw, 2 * math.pi))
            elif role == "pose":
                east, north = 10.0 * math.sin(yaw), 10.0 * (1.0 - math.cos(yaw))
                lat = LAT0 + math.degrees(north / 6_378_137.0)
                lon = LON0 + math.degrees(east / (6_378_137.0 * math.cos(math.radians(LAT0))))
                msg = m.nav_sat_fix(ns, lat, lon, sigma=0.05)
            else:
                msg = m.compressed_image(ns, jpegs[k % len(jpegs)], "jpeg")
            out.append((t, role, msg))
    return sorted(out, key=lambda item: item[0])


def measure(seconds: float, camera: bool, paced: bool) -> tuple[np.ndarray, float, int]:
    """Feed the schedule; return wheel latencies (s), the wall time, frames classified."""
    arrived: dict[int, float] = {}
    latency: list[float] = []

    def on_output(out: LiveOutput) -> None:
        start = arrived.pop(out.stamp_ns, None)
        if start is not None:
            latency.append(time.perf_counter() - start)

    topics = LiveTopics("/joint_states", pose="/fix", heading="/imu", images="/camera/compressed")
    live = build_live(
        SAMPLE / "config.yaml",
        topics if camera else LiveTopics("/joint_states", pose="/fix", heading="/imu"),
        LiveOptions(delay=0.0),
        on_output=on_output,
    )
    plan = schedule(seconds, camera)
    start = time.perf_counter()
    for t, role, msg in plan:
        if paced:
            wait = start + t - time.perf_counter()
            if wait > 0:
                time.sleep(wait)
        if role == "wheels":
            stamp = msg.header.stamp
            arrived[stamp.sec * 10**9 + stamp.nanosec] = time.perf_counter()
        live.message(role, TYPES[role], msg)
        if paced and role == "wheels":
            live.poll()
    live.close()
    wall = time.perf_counter() - start
    return np.array(latency), wall, live.counts["frames_classified"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="s of messages (default 20)")
    args = parser.parse_args()
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})  # one core
    load = os.getloadavg()
    print(f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on {os.cpu_count()} cores; "
          f"pinned to one core")  # fmt: skip
    wheels = int(args.seconds * RATES["wheels"])
    print(f"{args.seconds:g} s: wheels 100 Hz, IMU 50 Hz, GPS 5 Hz, camera 10 Hz (JPEG 320x240)")
    print("latency wheel message -> odometry, ms   median      p99      max   frames")
    for camera in (False, True):
        lat, _, frames = measure(args.seconds, camera, paced=True)
        ms = 1e3 * lat
        label = "camera on " if camera else "camera off (baseline)"
        print(
            f"  {label:36s} {np.median(ms):7.3f}  {np.percentile(ms, 99):7.3f}  "
            f"{ms.max():7.2f}   {frames}"
        )
        assert lat.size == wheels, f"{lat.size} outputs for {wheels} wheel messages"
    lat, wall, frames = measure(args.seconds, True, paced=False)
    print(
        f"sustained, as fast as it goes: {wheels / wall:,.0f} wheel messages/s "
        f"({wheels / wall / RATES['wheels']:.1f}x real time; {frames} frames classified, "
        f"{len(lat)} rows of wheels)"
    )


if __name__ == "__main__":
    main()
