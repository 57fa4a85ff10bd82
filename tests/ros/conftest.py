"""A real ROS 1 master for the node's tests, and the processes around it.

The node runs in Debian's Python (``rospy`` is a Debian package): a venv made
from ``/usr/bin/python3`` with ``--system-site-packages`` and the project
installed into it (docs/ros.md; ``.ci/run`` makes ``.venv-ros``).
``TERRAIN_ODOM_ROS_PYTHON`` names another interpreter. Without ``roscore``
or that interpreter, the tests are skipped with the reason.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import pytest

from tests.conftest import REPO

ROS_PYTHON = Path(os.environ.get("TERRAIN_ODOM_ROS_PYTHON", REPO / ".venv-ros" / "bin" / "python"))
HERE = Path(__file__).resolve().parent
collect_ignore = ["publish_bad.py"]  # a script for Debian's Python (rospy), run by the tests


@pytest.fixture(scope="session")
def ros_python() -> str:
    """Return the interpreter that runs the node (``rospy`` and terrain-odom importable)."""
    if shutil.which("roscore") is None:
        pytest.skip(
            "ROS 1 is not installed (no roscore): apt-get install ros-core python3-rospy ... "
            "(docs/ros.md)"
        )
    if not ROS_PYTHON.is_file():
        pytest.skip(
            f"no Debian-Python venv at {ROS_PYTHON}: /usr/bin/python3 -m venv "
            "--system-site-packages .venv-ros && .venv-ros/bin/pip install -e . (docs/ros.md)"
        )
    check = subprocess.run(
        [str(ROS_PYTHON), "-c", "import rospy, roslib.message, terrain_odom.ros.node"],
        capture_output=True,
        text=True,
    )
    if check.returncode != 0:
        last = (check.stderr.strip().splitlines() or ["?"])[-1]
        pytest.skip(f"{ROS_PYTHON} cannot import rospy and terrain-odom: {last} (docs/ros.md)")
    return str(ROS_PYTHON)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def wait_for(what: str, predicate: Callable[[], bool], timeout: float) -> None:
    """Wait until ``predicate()`` holds, failing with ``what`` after ``timeout`` s."""
    end = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > end:
            raise AssertionError(f"timed out after {timeout} s waiting for {what}")
        time.sleep(0.2)


class Ros:
    """The environment of a running master, and the processes started in it."""

    def __init__(self, env: dict[str, str], folder: Path, python: str) -> None:
        self.env, self.folder, self.python = env, folder, python
        self.procs: list[subprocess.Popen[bytes]] = []

    def tool(self, *args: str, timeout: float = 30.0) -> str:
        """Run a ROS command-line tool (rosparam, rosnode, ...) to completion; its stdout."""
        out = subprocess.run(
            list(args), env=self.env, capture_output=True, text=True, timeout=timeout
        )
        return out.stdout

    def start(self, args: Sequence[str], log: str) -> subprocess.Popen[bytes]:
        """Start a process in its own session (signals go to it alone), output to ``log``."""
        with open(self.folder / log, "wb") as handle:
            proc = subprocess.Popen(
                list(args),
                env=self.env,
                stdout=handle,
                stderr=subprocess.STDOUT,
                stdin=subprocess.DEVNULL,
                start_new_session=True,
            )
        self.procs.append(proc)
        return proc

    def log(self, name: str) -> str:
        """Return what a process started with ``log=name`` has written so far."""
        return (self.folder / name).read_text(errors="replace")

    def node(self, args: Sequence[str], log: str = "node.log") -> subprocess.Popen[bytes]:
        """Start ``terrain-odom-ros`` and wait until it listens."""
        proc = self.start([self.python, "-m", "terrain_odom.ros.node", *args], log)
        wait_for(
            "the node to listen",
            lambda: "listening to" in self.log(log) or proc.poll() is not None,
            120.0,
        )
        assert proc.poll() is None, self.log(log)
        return proc

    def record(self, out: Path, topics: Sequence[str]) -> subprocess.Popen[bytes]:
        """Start ``rosbag record`` of ``topics`` into ``out`` and wait until it subscribed."""
        proc = self.start(
            ["rosbag", "record", "-O", str(out), *topics, "__name:=recorder"], "rec.log"
        )
        wait_for("the recorder", lambda: "/recorder" in self.tool("rosnode", "list"), 60.0)
        wait_for(
            "the recorder to subscribe",
            lambda: (
                "Subscribing to" in self.log("rec.log")
                or "recorder" in self.tool("rostopic", "info", topics[0])
            ),
            30.0,
        )
        return proc

    @staticmethod
    def stop(proc: subprocess.Popen[bytes], sig: int = signal.SIGINT, timeout: float = 30.0) -> int:
        """Send ``sig`` to a process's session; return its exit code."""
        if proc.poll() is None:
            os.killpg(proc.pid, sig)
        try:
            return proc.wait(timeout)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
            raise AssertionError(f"{proc.args!r} did not stop on signal {sig}") from None

    def stop_all(self) -> None:
        """Stop every process still running (SIGINT, then SIGKILL), the latest first."""
        for proc in reversed(self.procs):
            if proc.poll() is None:
                try:
                    self.stop(proc, timeout=15.0)
                except AssertionError:
                    pass


@pytest.fixture(scope="module")
def ros(ros_python: str, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Ros]:
    """Start a ``roscore`` on a free port (``ROS_MASTER_URI`` set for every process started)."""
    folder = tmp_path_factory.mktemp("ros")
    port = _free_port()
    env = {k: v for k, v in os.environ.items() if not k.startswith(("ROS_", "VIRTUAL_ENV"))} | {
        "ROS_MASTER_URI": f"http://127.0.0.1:{port}",
        "ROS_HOSTNAME": "127.0.0.1",
        "ROS_HOME": str(folder / "home"),
        "ROS_LOG_DIR": str(folder / "log"),
        "PYTHONUNBUFFERED": "1",
    }
    env["PATH"] = os.pathsep.join(
        p for p in env.get("PATH", "").split(os.pathsep) if Path(sys.prefix) not in Path(p).parents
    )
    ros = Ros(env, folder, ros_python)
    core = ros.start(["roscore", "-p", str(port)], "roscore.log")
    try:
        wait_for("roscore", lambda: "/rosout" in ros.tool("rosnode", "list"), 60.0)
        yield ros
    finally:
        ros.procs.remove(core)
        ros.stop_all()
        ros.stop(core)


def read_bag(path: Path) -> dict[str, list[tuple[int, Any]]]:
    """Return the messages of a recorded bag by topic: ``(receive ns, message)``."""
    from terrain_odom.io.bag.reader import open_bag, stream_messages

    # rosbag record's C++ child closes the file after the wrapper the test stopped has exited
    active = path.with_name(path.name + ".active")
    wait_for(f"{path.name} closed", lambda: path.is_file() and not active.exists(), 60.0)
    out: dict[str, list[tuple[int, Any]]] = {}
    with open_bag(path) as reader:
        for m in stream_messages(reader, path, list(reader.connections), False):
            out.setdefault(m.topic, []).append((m.receive_ns, m.msg))
    return out
