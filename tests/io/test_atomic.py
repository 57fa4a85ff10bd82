"""Tests of the shared atomic writer."""

from __future__ import annotations

import pytest

from terrain_odom.io.atomic import write_atomic


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
