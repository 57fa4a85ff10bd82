"""Output folders: the manifest of what wrote which file, and the lock (issue 24)."""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from terrain_odom.errors import InputFileError
from terrain_odom.io.atomic import OutputFileError
from terrain_odom.io.folder import (
    MANIFEST,
    FolderInUseError,
    create_folder,
    holder,
    replacing,
    writing,
)

SRC = Path(__file__).resolve().parents[2] / "src"


def _files(folder: Path) -> dict[str, bytes]:
    return {
        p.relative_to(folder).as_posix(): p.read_bytes() for p in folder.rglob("*") if p.is_file()
    }


def test_the_manifest_records_each_file_with_its_writer_and_hash(tmp_path: Path) -> None:
    with replacing(tmp_path / "out", "import", ["log.csv", "frames/"]) as out:
        (out / "log.csv").write_text("t\n")
        (out / "frames").mkdir()
        (out / "frames" / "000000.jpg").write_bytes(b"jpeg")
    manifest = json.loads((tmp_path / "out" / MANIFEST).read_text())
    assert "holder" not in manifest  # released
    assert manifest["files"] == {
        "frames/000000.jpg": {"command": "import", "sha256": hashlib.sha256(b"jpeg").hexdigest()},
        "log.csv": {"command": "import", "sha256": hashlib.sha256(b"t\n").hexdigest()},
    }


def test_own_files_are_replaced_and_the_rest_refused_or_kept(tmp_path: Path) -> None:
    """Own previous files: removed (all, also those not written again); others: kept or refused."""
    out = tmp_path / "out"
    with replacing(out, "import", ["log.csv", "config.yaml", "frames/"]):
        (out / "log.csv").write_text("1")
        (out / "config.yaml").write_text("a: 1")
        (out / "frames").mkdir()
        (out / "frames" / "0.jpg").write_bytes(b"x")
    (out / "notes.txt").write_text("mine")
    with replacing(out, "import", ["log.csv", "config.yaml", "frames/"]):
        assert not (out / "frames").exists()  # the previous import's frames: gone
        (out / "log.csv").write_text("2")
        (out / "config.yaml").write_text("a: 2")
    assert _files(out).keys() == {MANIFEST, "log.csv", "config.yaml", "notes.txt"}
    # another command's file, an edited file, an unknown file: refused, nothing touched
    before = _files(out)
    with pytest.raises(
        InputFileError, match="config.yaml: written by terrain-odom import, and run"
    ):
        with replacing(out, "run", ["config.yaml"]):
            pass
    (out / "config.yaml").write_text("a: 3  # edited")
    before = _files(out)
    with pytest.raises(InputFileError, match="config.yaml: edited since terrain-odom import"):
        with replacing(out, "import", ["log.csv", "config.yaml"]):
            pass
    with pytest.raises(InputFileError, match="notes.txt: not written by terrain-odom run"):
        with replacing(out, "run", ["notes.txt"]):
            pass
    assert _files(out) == before


def test_without_overwrite_own_files_are_refused(tmp_path: Path) -> None:
    with replacing(tmp_path, "degrade", ["log.csv"]):
        (tmp_path / "log.csv").write_text("1")
    with pytest.raises(InputFileError, match="already holds the files of terrain-odom degrade"):
        with replacing(tmp_path, "degrade", ["log.csv"], overwrite=False):
            pass
    assert (tmp_path / "log.csv").read_text() == "1"


def test_a_file_being_written_when_killed_counts_as_the_writers(tmp_path: Path) -> None:
    """A pending entry (sha256 null: the process died) is the command's own, whatever it holds."""
    with writing(tmp_path, "run") as folder:
        folder.prepare(["trajectory.csv"], overwrite=False)
        manifest = json.loads((tmp_path / MANIFEST).read_text())
        assert manifest["files"]["trajectory.csv"] == {"command": "run", "sha256": None}
        assert manifest["holder"]["pid"] == os.getpid()
        (tmp_path / "trajectory.csv").write_text("t\n0")
        saved = (tmp_path / MANIFEST).read_text()
    (tmp_path / MANIFEST).write_text(saved)  # as if the process had been killed here
    with replacing(tmp_path, "run", ["trajectory.csv"]):
        assert not (tmp_path / "trajectory.csv").exists()


def test_a_second_writer_is_refused_naming_the_holder(tmp_path: Path) -> None:
    """Another process holds the folder: one line with its command, process and start."""
    script = (
        "import sys, time\n"
        "from terrain_odom.io.folder import writing\n"
        "with writing(sys.argv[1], 'run'):\n"
        "    print('locked', flush=True)\n"
        "    time.sleep(60)\n"
    )
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    child = subprocess.Popen(
        [sys.executable, "-c", script, str(tmp_path)], stdout=subprocess.PIPE, env=env, text=True
    )
    try:
        assert child.stdout is not None and child.stdout.readline() == "locked\n"
        held = holder(tmp_path)
        assert held is not None and held.pid == child.pid and held.command == "run"
        with pytest.raises(
            FolderInUseError, match=rf"in use by terrain-odom run \(process {child.pid}, since 20"
        ):
            with writing(tmp_path, "import"):
                pass
    finally:
        child.kill()
        child.communicate()
    # the lock went with the process: no stale lock
    assert holder(tmp_path) is None
    with writing(tmp_path, "import"):
        assert holder(tmp_path) is not None


def test_a_folder_that_cannot_be_created_is_one_error_naming_it(tmp_path: Path) -> None:
    long = tmp_path / ("x" * 300)
    with pytest.raises(OutputFileError, match="File name too long"):
        create_folder(long / "out")
    (tmp_path / "file").write_text("")
    with pytest.raises(InputFileError, match="a file of that name exists"):
        create_folder(tmp_path / "file")
    with pytest.raises(OutputFileError, match="Not a directory"):
        create_folder(tmp_path / "file" / "out")


def test_a_manifest_naming_files_elsewhere_never_removes_them(tmp_path: Path) -> None:
    """A hand-edited manifest pointing outside the folder (or malformed) is ignored there."""
    outside = tmp_path / "precious.txt"
    outside.write_text("keep me")
    out = tmp_path / "out"
    out.mkdir()
    entry = {"command": "run", "sha256": None}
    files = {str(outside): entry, "../precious.txt": entry, "bad": 5, "worse": {"command": 1}}
    (out / MANIFEST).write_text(json.dumps({"format": 1, "files": files}))
    with replacing(out, "run", ["report.json"]):
        (out / "report.json").write_text("{}")
    assert outside.read_text() == "keep me"
    assert set(json.loads((out / MANIFEST).read_text())["files"]) == {"report.json"}
