"""Tests of the shared atomic writer."""

from __future__ import annotations

import os

import pytest

from terrain_odom.errors import TerrainOdomError
from terrain_odom.io.atomic import OutputFileError, write_atomic


def test_writes_and_replaces(tmp_path):
    path = tmp_path / "f.bin"
    write_atomic(path, lambda h: h.write(b"one"))
    write_atomic(path, lambda h: h.write(b"two"))
    assert path.read_bytes() == b"two"
    assert [p.name for p in tmp_path.iterdir()] == ["f.bin"]


def test_failure_keeps_the_old_file_and_leaves_no_temporary(tmp_path):
    path = tmp_path / "f.bin"
    path.write_bytes(b"old")

    def broken(handle):
        handle.write(b"half")
        raise RuntimeError("boom")

    with pytest.raises(RuntimeError, match="boom"):
        write_atomic(path, broken)
    assert path.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["f.bin"]


def test_missing_folder_names_the_folder(tmp_path):
    with pytest.raises(FileNotFoundError) as info:
        write_atomic(tmp_path / "nope" / "f.bin", lambda h: h.write(b""))
    assert info.value.filename == str(tmp_path / "nope")


def test_missing_folder_names_the_target_too(tmp_path):
    with pytest.raises(FileNotFoundError, match="cannot write .*f.bin"):
        write_atomic(tmp_path / "nope" / "f.bin", lambda h: h.write(b""))


def test_a_parent_that_is_a_file_names_the_target(tmp_path):
    (tmp_path / "file").write_text("x")
    with pytest.raises(FileNotFoundError, match="cannot write .*file/f.bin"):
        write_atomic(tmp_path / "file" / "f.bin", lambda h: h.write(b""))


def test_os_errors_name_the_target_not_the_temporary(tmp_path):
    target = tmp_path / "folder"
    target.mkdir()  # replacing a folder by a file fails in os.replace
    with pytest.raises(OutputFileError) as info:
        write_atomic(target, lambda h: h.write(b"x"))
    assert info.value.filename == str(target)
    assert str(info.value).startswith(f"{target}: cannot write (")
    assert ".tmp" not in str(info.value)
    assert isinstance(info.value, OSError) and isinstance(info.value, TerrainOdomError)
    assert [p.name for p in tmp_path.iterdir()] == ["folder"]


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_read_only_folder_names_the_target(tmp_path):
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o500)
    try:
        with pytest.raises(OutputFileError, match=r"ro/f.bin: cannot write \(Permission denied\)"):
            write_atomic(folder / "f.bin", lambda h: h.write(b""))
    finally:
        folder.chmod(0o700)
