"""Fixtures shared by every test folder: the repository and the real data beside it.

The real data (``../shared/data`` next to the repository: Warthog drive logs,
indoor floor photos) is not part of the project; a test that asks for it is
skipped, with the reason, where it is absent.
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO.parent / "shared" / "data"


def _shared(name: str) -> Path:
    path = SHARED_DATA / name
    if not path.is_dir():
        pytest.skip(f"real data not present: {path} (../shared beside the repository)")
    return path


@pytest.fixture(scope="session")
def examples_dir() -> Path:
    """Return the repository's ``examples/`` (the demo log and its configuration)."""
    return REPO / "examples"


@pytest.fixture(scope="session")
def sample_dir() -> Path:
    """Return the quick start's simulated run with camera frames (``sample_images/chen2023``)."""
    return REPO / "sample_images" / "chen2023"


@pytest.fixture(scope="session")
def warthog_yaml() -> Path:
    """Return the Warthog configuration the real drive logs were recorded with."""
    return REPO / "config" / "warthog.yaml"


@pytest.fixture(scope="session")
def drive_dir() -> Path:
    """Return ``../shared/data/drive``: real Warthog wheel logs with ICP ground truth."""
    return _shared("drive")


@pytest.fixture(scope="session")
def indoor_dir() -> Path:
    """Return ``../shared/data/indoor_surface``: 1,774 real floor photos (carpet, tiles, wood)."""
    return _shared("indoor_surface")


@pytest.fixture(scope="session")
def jackal_bag() -> Path:
    """Return ``../shared/data/bags/jackal_odom_imu.bag``: a real ROS 1 bag (odometry, IMU)."""
    path = _shared("bags") / "jackal_odom_imu.bag"
    if not path.is_file():
        pytest.skip(f"real data not present: {path} (../shared beside the repository)")
    return path


@pytest.fixture(scope="session")
def sample_camera_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    """Run the camera quick start once (``run --images sample_images/chen2023 ...``).

    Return its output folder and what it printed. Tests only read them.
    """
    import contextlib
    import io

    from terrain_odom.cli.main import main

    sample = REPO / "sample_images" / "chen2023"
    out = tmp_path_factory.mktemp("sample_run") / "out"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        code = main(
            ["run", "--images", str(sample), "--wheels", str(sample / "log.csv"), "--out", str(out)]
        )
    assert code == 0, printed.getvalue()
    return out, printed.getvalue()


@pytest.fixture(scope="module")
def scheduler() -> Iterator[str]:
    """Return the address of a Dask scheduler with 2 single-thread workers (threads of this process).

    Skipped where dask.distributed (the ``[dask]`` extra) is not installed.
    """
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=False, dashboard_address=":0"
    ) as local:
        yield local.scheduler_address


@pytest.fixture(scope="session", autouse=True)
def _no_worker_processes_left() -> Iterator[None]:
    """Stop joblib's worker processes when the tests end, and wait for them.

    Left alone, they exit on their own after 300 s idle, and whoever waits for
    any child of this process then gets them: mutmut, which runs the tests in
    its own process and then waits for its forked mutant runs, stopped on an
    unknown pid (docs/testing.md).
    """
    yield
    if "joblib.externals.loky.reusable_executor" in sys.modules:
        executor = sys.modules["joblib.externals.loky.reusable_executor"]._executor
        if executor is not None:
            executor.shutdown(wait=True)
