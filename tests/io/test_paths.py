"""Tests of the output-path check: an output never overwrites an input."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from terrain_odom.errors import InputFileError
from terrain_odom.io.paths import check_outputs


def test_same_file_is_refused_naming_both(tmp_path: Path) -> None:
    log = tmp_path / "log.csv"
    log.write_text("t\n0\n")
    with pytest.raises(InputFileError) as info:
        check_outputs([log], [tmp_path / "." / "log.csv"])
    assert str(log) in str(info.value) and "refusing to overwrite" in str(info.value)


def test_links_to_an_input_are_refused(tmp_path: Path) -> None:
    log = tmp_path / "log.csv"
    log.write_text("t\n0\n")
    (tmp_path / "soft.csv").symlink_to(log)
    os.link(log, tmp_path / "hard.csv")
    for name in ("soft.csv", "hard.csv"):
        with pytest.raises(InputFileError):
            check_outputs([log], [tmp_path / name])


def test_other_missing_and_absent_paths_pass(tmp_path: Path) -> None:
    log = tmp_path / "log.csv"
    log.write_text("t\n0\n")
    other = tmp_path / "other.csv"
    other.write_text("t\n0\n")
    check_outputs([log, None, tmp_path / "missing.csv"], [other, tmp_path / "new.csv"])
    check_outputs([], [log])
