"""Speed and memory of ``terrain-odom import``: the real bag, and synthetic bags of growing size.

Each import runs in its own process (``python -m terrain_odom import``) so its
peak resident memory (``ru_maxrss``) is its own. Printed per bag: size,
messages, import time, MB/s, peak memory, and the ratio of the import time
to one plain pass over the same bag's messages (read, not deserialised),
measured in the same run. The synthetic bags (ROS 1; JointState at 100 Hz,
PoseStamped at 10 Hz, raw 320x240 ``bgr8`` images at 5 Hz) grow 4x in
length: a streaming import keeps the same peak memory. The figures are those
of docs/bags.md, "Speed and memory".

Usage::

    python bench/bag_import.py [--seconds 120 480]
"""

from __future__ import annotations

import argparse
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from terrain_odom.io.bag.reader import open_bag
from terrain_odom.io.bag.writer import MessageFactory, Record, write_bag

REPO = Path(__file__).resolve().parents[1]
REAL = REPO.parent / "shared" / "data" / "bags" / "jackal_odom_imu.bag"
JOINTS = ["left_wheel", "right_wheel"]


def _records(seconds: float) -> list[Record]:
    """Return the records of a synthetic recording of ``seconds`` (receive time = header stamp)."""
    m, rng = MessageFactory(), np.random.default_rng(0)
    image = rng.integers(0, 255, (240, 320, 3), dtype=np.uint8)
    base, out = 1_700_000_000 * 10**9, []
    for k in range(int(seconds * 100)):
        ns = base + k * 10_000_000
        out.append(
            (
                "/joint_states",
                "sensor_msgs/msg/JointState",
                ns,
                m.joint_state(ns, JOINTS, [5.0, 5.0 + math.sin(k / 300)]),
            )
        )
        if k % 10 == 0:
            out.append(
                (
                    "/pose",
                    "geometry_msgs/msg/PoseStamped",
                    ns,
                    m.pose_stamped(ns, 0.01 * k, 0.0, 0.0),
                )
            )
        if k % 20 == 0:
            out.append(("/cam/image_raw", "sensor_msgs/msg/Image", ns, m.image(ns, image)))
    return out


def _pass_seconds(bag: Path) -> float:
    """Time of one pass over every message of ``bag`` (not deserialised)."""
    started = time.perf_counter()
    with open_bag(bag) as reader:
        for _ in reader.messages():
            pass
    return time.perf_counter() - started


_CHILD = (
    "import resource, sys; from terrain_odom.cli.main import main; rc = main(sys.argv[1:]); "
    "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, file=sys.stderr); sys.exit(rc)"
)


def _import(bag: Path, out: Path, args: list[str]) -> tuple[float, float]:
    """Run the import in a child process; return its wall time (s) and peak memory (MB)."""
    started = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", _CHILD, "import", str(bag), "--out", str(out), *args],
        check=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    seconds = time.perf_counter() - started
    return seconds, int(done.stderr.split()[-1]) / 1024


def _size(path: Path) -> float:
    files = [path] if path.is_file() else list(path.rglob("*"))
    return sum(f.stat().st_size for f in files if f.is_file()) / 1e6


def _line(name: str, bag: Path, out: Path, args: list[str]) -> None:
    with open_bag(bag) as reader:
        messages = reader.message_count
    base = _pass_seconds(bag)
    seconds, peak = _import(bag, out, args)
    size = _size(bag)
    print(
        f"{name:<24} {size:8.1f} {messages:9d} {seconds:8.2f} {size / seconds:7.1f} "
        f"{peak:8.0f} {seconds / base:8.1f}"
    )


def main() -> None:
    """Print one line per bag."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, nargs="+", default=[120.0, 480.0])
    lengths = parser.parse_args().seconds
    print(
        f"{'bag':<24} {'MB':>8} {'messages':>9} {'import s':>8} {'MB/s':>7} {'peak MB':>8} "
        f"{'x pass':>8}"
    )
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder)
        if REAL.is_file():
            real_args = [
                "--wheels-topic",
                "/jackal_velocity_controller/odom",
                "--heading-topic",
                "/imu/data",
                "--track-width",
                "0.563",
            ]
            _line("jackal_odom_imu.bag", REAL, tmp / "real", real_args)
        args = [
            "--wheels-topic",
            "/joint_states",
            "--wheel-radius",
            "0.1",
            "--left-joints",
            "left*",
            "--right-joints",
            "right*",
            "--pose-topic",
            "/pose",
            "--image-topic",
            "/cam/image_raw",
        ]
        for seconds in lengths:
            bag = write_bag(tmp / f"synthetic_{seconds:.0f}s.bag", "ros1", _records(seconds))
            _line(f"synthetic {seconds:.0f} s", bag, tmp / f"out{seconds:.0f}", args)
            bag.unlink()


if __name__ == "__main__":
    main()
