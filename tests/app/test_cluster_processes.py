"""A real ``dask scheduler`` and ``dask worker`` processes on loopback, started and stopped here.

``compare`` sent to them (``--dask tcp://127.0.0.1:PORT``) must give what it
gives in this process: the same parameters and errors, the same order.
"""

from __future__ import annotations

import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from terrain_odom.app.fit import compare
from terrain_odom.app.simulate import SimOutput
from terrain_odom.fitting import FitOptions

distributed = pytest.importorskip("distributed")

DASK = Path(sys.executable).with_name("dask")
STARTUP = 60.0
"""Seconds the processes get to start on a busy machine."""


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _wait_for_workers(address: str, count: int) -> None:
    deadline = time.monotonic() + STARTUP
    while True:
        try:
            with distributed.Client(address, timeout=5) as client:
                client.wait_for_workers(count, timeout=max(1.0, deadline - time.monotonic()))
                return
        except OSError:  # the scheduler is not listening yet
            if time.monotonic() > deadline:
                raise
            time.sleep(0.5)


def _stop(process: subprocess.Popen[bytes]) -> None:
    process.terminate()
    try:
        process.wait(timeout=15)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait(timeout=15)


@pytest.fixture
def scheduler_address(tmp_path: Path) -> Iterator[str]:
    """Start ``dask scheduler`` and ``dask worker`` (2 processes, 1 thread each); stop them after."""
    if not DASK.is_file():
        pytest.skip(f"no dask command beside {sys.executable}")
    address = f"tcp://127.0.0.1:{_free_port()}"
    logs = [open(tmp_path / f"{name}.log", "wb") for name in ("scheduler", "worker")]
    started: list[subprocess.Popen[bytes]] = []
    try:
        started.append(
            subprocess.Popen(
                [str(DASK), "scheduler", "--host", "127.0.0.1", "--port", address.rsplit(":", 1)[1]]
                + ["--dashboard-address", ":0"],
                stdout=logs[0],
                stderr=subprocess.STDOUT,
            )
        )
        started.append(
            subprocess.Popen(
                [str(DASK), "worker", address, "--nworkers", "2", "--nthreads", "1"]
                + ["--host", "127.0.0.1", "--dashboard-address", ":0"],
                stdout=logs[1],
                stderr=subprocess.STDOUT,
            )
        )
        _wait_for_workers(address, 2)
        yield address
    finally:
        for process in reversed(started):
            _stop(process)
        for handle in logs:
            handle.close()


def test_compare_on_dask_processes_is_the_same(sim_output: SimOutput, scheduler_address: str):
    args = dict(models=["edd-asym", "idd", "roc"], horizon="1m")
    args["options"] = FitOptions(popsize=6, maxiter=8, seed=2)
    here = compare([sim_output.log_csv], [sim_output.log_csv], **args)
    there = compare([sim_output.log_csv], [sim_output.log_csv], dask=scheduler_address, **args)
    assert list(there.models) == list(here.models) == ["edd-asym", "idd", "roc"]
    for name, mine in here.models.items():
        theirs = there.models[name]
        assert theirs.errors == mine.errors
        assert theirs.params.sets.keys() == mine.params.sets.keys()
        for key, mine_set in mine.params.sets.items():
            assert theirs.params.sets[key].params == mine_set.params
            assert theirs.params.sets[key].fit["loss"] == mine_set.fit["loss"]
