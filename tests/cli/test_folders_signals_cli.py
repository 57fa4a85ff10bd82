"""Issue 24: no lost work, every signal, every disk: real processes, real signals, a full disk.

Each refusal is one line on stderr, exit code 2, no traceback, and leaves
the files it was given byte-identical.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np
import pytest

from terrain_odom.cli.main import main
from terrain_odom.io.bag.writer import MessageFactory, write_bag
from terrain_odom.io.folder import MANIFEST
from terrain_odom.io.trajectory import read_trajectory_csv

SRC = Path(__file__).resolve().parents[2] / "src"
M = MessageFactory()
BASE = 1_700_000_000 * 10**9
SLOW_RUN = """\
import sys, time
from terrain_odom.io.trajectory import TrajectoryBlocks
from terrain_odom.cli.main import main

real = TrajectoryBlocks.write

def slow(self, *args, **kwargs):
    real(self, *args, **kwargs)
    print("block", flush=True)
    time.sleep(60)

TrajectoryBlocks.write = slow
sys.exit(main(sys.argv[1:]))
"""
"""``terrain-odom`` whose run waits a minute after its first block of rows."""


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {
        p.relative_to(folder).as_posix(): p.read_bytes() for p in folder.rglob("*") if p.is_file()
    }


def _one_line(err: str) -> str:
    assert err.count("\n") == 1 and err.startswith("terrain-odom: error: "), err
    assert "Traceback" not in err
    return err


def _refused(argv: list[str], capsys: pytest.CaptureFixture[str], *folders: Path) -> str:
    """Run ``argv``: exit 2, one line, every file under ``folders`` byte-identical; the line."""
    before = [_snapshot(f) for f in folders]
    capsys.readouterr()
    assert main(argv) == 2
    err = _one_line(capsys.readouterr().err)
    assert [_snapshot(f) for f in folders] == before
    return err


def _bag(tmp_path: Path, images: bool) -> Path:
    """Write a 1-s MCAP bag: Odometry at 20 Hz (and 3 camera images)."""
    ns = [BASE + k * 50_000_000 for k in range(21)]
    records = [("/odom", "nav_msgs/msg/Odometry", t, M.odometry(t, twist=(0.5, 0.2))) for t in ns]
    if images:
        raw = np.random.default_rng(0).integers(0, 255, (24, 32, 3), dtype=np.uint8)
        records += [
            ("/cam/image_raw", "sensor_msgs/msg/Image", t, M.image(t, raw)) for t in ns[2:8:2]
        ]
    folder = write_bag(
        tmp_path / ("cam" if images else "plain"), "mcap", sorted(records, key=lambda r: r[2])
    )
    return next(folder.glob("*.mcap"))


def _import(bag: Path, out: Path, *extra: str) -> list[str]:
    return [
        "import",
        str(bag),
        "--out",
        str(out),
        "--wheels-topic",
        "/odom",
        "--track-width",
        "0.4",
        *extra,
    ]


def test_run_into_an_import_folder_never_replaces_its_config(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The import's config.yaml (hand-edited or not) is not the run's: refused, with --overwrite too."""
    out = tmp_path / "imported"
    assert main(_import(_bag(tmp_path, False), out)) == 0
    run = ["run", "--wheels", str(out / "log.csv"), "--out", str(out), "--no-checks"]
    err = _refused(run, capsys, out)
    assert "config.yaml: written by terrain-odom import, and run would replace it" in err
    with (out / "config.yaml").open("a") as handle:
        handle.write("# my edit\n")
    err = _refused([*run, "--overwrite"], capsys, out)
    assert "config.yaml: edited since terrain-odom import wrote it" in err


def test_reimport_keeps_an_edited_config_and_drops_old_frames(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "imported"
    cam, plain = _bag(tmp_path, True), _bag(tmp_path, False)
    assert main(_import(cam, out, "--image-topic", "/cam/image_raw")) == 0
    assert len(list((out / "frames").iterdir())) == 3 and (out / "frames.csv").is_file()
    (out / "notes.txt").write_text("mine")
    # re-importing the same folder: the previous import's files are replaced ...
    assert main(_import(plain, out)) == 0
    names = sorted(_snapshot(out))
    assert names == [MANIFEST, "config.yaml", "import.json", "log.csv", "notes.txt"]
    # ... but never a config.yaml edited by hand
    config = out / "config.yaml"
    config.write_text(config.read_text().replace("track_width: 0.4", "track_width: 0.45"))
    err = _refused(_import(cam, out, "--image-topic", "/cam/image_raw"), capsys, out)
    assert "config.yaml: edited since terrain-odom import wrote it" in err


def _default_signals() -> None:
    """Give the child the default signal handlers.

    A suite started by ``nohup`` or ``&`` ignores SIGHUP/SIGINT, and the CLI keeps an
    inherited ignore (``nohup``'s meaning): the test is of the CLI, not of its shell.
    """
    for number in (signal.SIGTERM, signal.SIGHUP, signal.SIGINT):
        signal.signal(number, signal.SIG_DFL)


def _start_slow_run(log: Path, out: Path, *extra: str) -> subprocess.Popen[str]:
    """Start a run that waits after its first block; return once that block is written."""
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    argv = ["run", "--wheels", str(log), "--out", str(out), "--no-checks", "--no-plots", *extra]
    child = subprocess.Popen(
        [sys.executable, "-c", SLOW_RUN, *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
        text=True,
        preexec_fn=_default_signals,
    )
    assert child.stdout is not None
    line = child.stdout.readline()
    if line != "block\n":
        child.kill()
        raise AssertionError(f"no block written: {line!r} {child.communicate()}")
    return child


@contextlib.contextmanager
def _slow_run(log: Path, out: Path, *extra: str) -> Iterator[subprocess.Popen[str]]:
    child = _start_slow_run(log, out, *extra)
    try:
        yield child
    finally:
        if child.poll() is None:
            child.kill()
        child.communicate()


@pytest.mark.parametrize("number", [signal.SIGTERM, signal.SIGHUP, signal.SIGINT])
def test_a_signal_stops_a_run_as_ctrl_c(
    number: signal.Signals, examples_dir: Path, tmp_path: Path
) -> None:
    """SIGTERM, SIGHUP, SIGINT: status interrupted with the reason and the rows written."""
    out = tmp_path / "out"
    with _slow_run(examples_dir / "demo_log.csv", out) as child:
        child.send_signal(number)
        _, err = child.communicate(timeout=60)
    expected = 130 if number == signal.SIGINT else 128 + number
    assert child.returncode == expected, err
    name = "" if number == signal.SIGINT else f" by {number.name}"
    assert err == f"terrain-odom: interrupted{name}; outputs written so far are kept\n"
    report = json.loads((out / "report.json").read_text())
    assert report["status"] == "interrupted"
    assert report["reason"] == (
        "interrupted by the user" if number == signal.SIGINT else f"interrupted by {number.name}"
    )
    rows = read_trajectory_csv(out / "trajectory.csv")["t"].size
    assert report["rows_written"] == rows > 0
    assert not [p for p in out.iterdir() if p.name.endswith(".tmp")]
    assert not (out / "trajectory.tum").exists()


def test_a_killed_run_is_named_interrupted_with_its_gone_process(
    examples_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """SIGKILL leaves "running"; nobody holds the folder, so its process is gone: said so."""
    log, out = examples_dir / "demo_log.csv", tmp_path / "out"
    with _slow_run(log, out) as child:
        child.kill()
        child.communicate()
    assert json.loads((out / "report.json").read_text())["status"] == "running"
    err = _refused(["run", "--wheels", str(log), "--out", str(out)], capsys, out)
    assert f"already holds an interrupted run (process {child.pid} is gone)" in err
    err = _refused(["evaluate", "--wheels", str(log), "--run", str(out)], capsys, out)
    assert f"(status: interrupted, process {child.pid} is gone)" in err
    # the killed run's files (trajectory.csv was being written) are its own: replaced
    assert [p.name for p in out.glob(".trajectory.tum.*.tmp")]  # left by SIGKILL
    assert main(["run", "--wheels", str(log), "--out", str(out), "--no-checks", "--overwrite"]) == 0
    assert not list(out.glob("*.tmp")) and not list(out.glob(".*.tmp"))


def test_a_second_command_on_a_running_folder_is_refused_naming_the_holder(
    examples_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Run --overwrite, evaluate --run while a run writes the folder: one line naming it."""
    log, out = examples_dir / "demo_log.csv", tmp_path / "out"
    with _slow_run(log, out) as child:
        holder = f"in use by terrain-odom run (process {child.pid}, since "
        err = _refused(["run", "--wheels", str(log), "--out", str(out), "--overwrite"], capsys)
        assert holder in err
        err = _refused(["evaluate", "--wheels", str(log), "--run", str(out)], capsys)
        assert f"the run is still running (terrain-odom run (process {child.pid}" in err
        assert json.loads((out / "report.json").read_text())["status"] == "running"
        child.send_signal(signal.SIGTERM)
        child.communicate(timeout=60)
    assert json.loads((out / "report.json").read_text())["status"] == "interrupted"


@contextlib.contextmanager
def _tmpfs(disk: Path, options: str) -> Iterator[Path]:
    """Mount a tmpfs with ``options`` on ``disk`` (root only; the test is skipped otherwise)."""
    disk.mkdir()
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(disk)], capture_output=True
    )
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.decode().strip()}")
    try:
        yield disk
    finally:
        subprocess.run(["umount", str(disk)], check=True)


@pytest.fixture
def small_disk(tmp_path: Path) -> Iterator[Path]:
    """Mount a 700-KiB tmpfs: room for a few hundred rows of a run, not for all."""
    with _tmpfs(tmp_path / "disk", "size=700k") as disk:
        yield disk


def test_a_full_disk_is_one_line_and_an_interrupted_run(
    small_disk: Path, examples_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """ENOSPC mid-run: the file and "no space left", status interrupted, whole rows, no temp file."""
    log, out = examples_dir / "demo_log.csv", small_disk / "run"
    (small_disk / "ballast").write_bytes(b"\0" * 300_000)  # the stream fills the rest
    err = _refused(["run", "--wheels", str(log), "--out", str(out), "--no-checks"], capsys)
    assert "no space left on the device" in err
    report = json.loads((out / "report.json").read_text())
    assert report["status"] == "interrupted" and "no space left" in report["reason"]
    text = (out / "trajectory.csv").read_text()
    assert text.endswith("\n")
    assert report["rows_written"] == read_trajectory_csv(out / "trajectory.csv")["t"].size
    assert not [p for p in out.iterdir() if p.name.endswith(".tmp")]
    assert not (out / "trajectory.tum").exists()


def test_a_full_disk_by_fault_injection(
    examples_dir: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """The same without root: a write cut short mid-row, then ENOSPC; the file cut to whole rows."""
    import errno

    from terrain_odom.io import trajectory

    calls = [0]
    real = os.write

    def write(fd: int, data: bytes) -> int:
        calls[0] += 1
        if calls[0] == 2:  # the first rows: half of them reach the disk
            return real(fd, bytes(data)[: len(data) // 2 + 7])
        if calls[0] > 2:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(fd, data)

    monkeypatch.setattr(trajectory.os, "write", write)
    log, out = examples_dir / "demo_log.csv", tmp_path / "run"
    err = _refused(["run", "--wheels", str(log), "--out", str(out), "--no-checks"], capsys)
    monkeypatch.undo()
    assert f"{out / 'trajectory.csv'}: cannot write: no space left on the device" in err
    report = json.loads((out / "report.json").read_text())
    assert report["status"] == "interrupted" and report["rows_written"] == 0
    header = (out / "trajectory.csv").read_text()
    assert header.startswith("t,x,y,yaw,") and header.count("\n") == 1 and header.endswith("\n")
    assert not [p for p in out.iterdir() if p.name.endswith(".tmp")]


LONG = "n" * 300
"""A file name longer than any file system allows (ENAMETOOLONG)."""


def _classes(root: Path) -> Path:
    """Two class folders of five small PNG images each."""
    rng = np.random.default_rng(1)
    for name in ("grass", "gravel"):
        (root / "classes" / name).mkdir(parents=True)
        for k in range(5):  # enough samples for k = 5 neighbours
            image = rng.integers(0, 255, (32, 32, 3), dtype=np.uint8)
            cv2.imwrite(str(root / "classes" / name / f"{k + 1}.0.png"), image)  # t, s
    (root / "frames").mkdir()
    for k in range(2):  # camera frames of the default camera's size, for patches
        cv2.imwrite(str(root / "frames" / f"{k + 1}.0.png"), np.full((480, 640, 3), 90, np.uint8))
    return root / "classes"


def _every_subcommand(log: Path, classes: Path, out: str) -> list[list[str]]:
    """One argument list per writing subcommand, writing into ``out``."""
    wheels = ["--wheels", str(log)]
    return [
        ["run", *wheels, "--out", out],
        ["evaluate", *wheels, "--out", out],
        ["fit", *wheels, "--model", "idd", "--out", out],
        ["compare", *wheels, "--eval", str(log), "--out", out],
        ["simulate", "--duration", "2", "--no-patches", "--out", out],
        ["degrade", *wheels, "--out", out],
        ["train", "--images", str(classes), "--out", out],
        ["report", "accuracy", "--images", str(classes), "--out", out],
        ["patches", *wheels, "--images", str(classes.parent / "frames"), "--out", out],
        ["import", str(log), "--wheels-topic", "/odom", "--out", out],
    ]


@pytest.mark.parametrize("index", range(10))
def test_an_out_folder_that_cannot_be_made_is_one_line_in_every_subcommand(
    index: int,
    examples_dir: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.chdir(tmp_path)
    log = tmp_path / "log.csv"
    log.write_bytes((examples_dir / "demo_log.csv").read_bytes())
    argv = _every_subcommand(log, _classes(tmp_path), f"{LONG}/out")[index]
    err = _refused(argv, capsys, tmp_path)
    assert "File name too long" in err or "is not one" in err  # import: a CSV is no bag


@pytest.mark.parametrize("subcommand", ["run", "evaluate", "fit", "import", "degrade"])
def test_a_wheel_log_with_a_300_character_name_is_one_line(
    subcommand: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = str(tmp_path / LONG)
    argv = {
        "run": ["run", "--wheels", log, "--out", str(tmp_path / "o")],
        "evaluate": ["evaluate", "--wheels", log],
        "fit": ["fit", "--wheels", log, "--model", "idd", "--out", str(tmp_path / "o")],
        "import": ["import", log, "--wheels-topic", "/odom", "--out", str(tmp_path / "o")],
        "degrade": ["degrade", "--wheels", log, "--out", str(tmp_path / "o")],
    }[subcommand]
    err = _refused(argv, capsys, tmp_path)
    assert f"{tmp_path}/nnnn" in err and "File name too long" in err


@pytest.fixture
def read_only(tmp_path: Path) -> Iterator[Path]:
    """Mount a read-only file system (root writes into read-only folders: chmod is no test)."""
    with _tmpfs(tmp_path / "ro", "ro,size=64k") as disk:
        yield disk


def test_a_read_only_out_is_one_line_in_every_subcommand(
    read_only: Path,
    examples_dir: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """``--out`` a folder to make in a read-only file system; ``simulate`` into one that exists."""
    classes = _classes(tmp_path)
    for argv in _every_subcommand(examples_dir / "demo_log.csv", classes, str(read_only / "out")):
        err = _refused(argv, capsys, tmp_path)
        assert "Read-only file system" in err or "is not one" in err, argv
    argv = ["simulate", "--duration", "2", "--no-patches", "--out", str(read_only)]
    assert f"{read_only}: cannot write (Read-only file system)" in _refused(argv, capsys)


def test_fit_replaces_its_own_file_keeps_other_models_and_refuses_an_edited_one(
    examples_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log, out = examples_dir / "demo_log.csv", tmp_path / "fits"
    fit = ["fit", "--wheels", str(log), "--maxiter", "1", "--popsize", "5", "--out", str(out)]
    assert main([*fit, "--model", "idd"]) == 0
    assert main([*fit, "--model", "edd-sym"]) == 0
    assert main([*fit, "--model", "idd"]) == 0  # its own file: replaced
    assert (out / "params_edd-sym.yaml").is_file()  # another model's: kept
    with (out / "params_idd.yaml").open("a") as handle:
        handle.write("# checked by hand\n")
    err = _refused([*fit, "--model", "idd"], capsys, out)
    assert "params_idd.yaml: edited since terrain-odom fit wrote it" in err
