"""Tests of :mod:`terrain_odom.io.report`: the JSON report header and writer."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import terrain_odom
from terrain_odom.io.report import (
    REPORT_FORMAT_VERSION,
    path_or_none,
    report_header,
    to_jsonable,
    write_json,
)


def test_header_names_the_format_version_the_package_and_the_command():
    assert report_header("evaluate") == {
        "format_version": REPORT_FORMAT_VERSION,
        "terrain_odom_version": terrain_odom.__version__,
        "command": "evaluate",
    }
    assert list(report_header("run")) == ["format_version", "terrain_odom_version", "command"]


def test_to_jsonable_turns_numpy_and_non_finite_floats_into_plain_data():
    data = {
        1: np.float64(0.5),
        "array": np.array([[1, 2], [3, 4]]),
        "tuple": (np.int64(3), math.nan, -math.inf),
        "nested": [{"x": np.array([np.nan, 1.5])}],
        "flag": np.bool_(True),
    }
    assert to_jsonable(data) == {
        "1": 0.5,
        "array": [[1, 2], [3, 4]],
        "tuple": [3, None, None],
        "nested": [{"x": [None, 1.5]}],
        "flag": True,
    }


def test_write_json_round_trips_and_replaces_an_existing_file(tmp_path: Path):
    path = tmp_path / "report.json"
    path.write_text("old")
    data = {**report_header("run"), "ate": np.float32(0.25), "missing": np.nan}
    write_json(path, data)
    text = path.read_text(encoding="utf-8")
    assert text.endswith("}\n") and "\n  " in text  # indented
    assert json.loads(text) == {**report_header("run"), "ate": 0.25, "missing": None}
    assert [p.name for p in tmp_path.iterdir()] == ["report.json"]  # no temporary left


def test_write_json_into_a_missing_folder_names_the_folder(tmp_path: Path):
    with pytest.raises(FileNotFoundError, match="directory does not exist") as err:
        write_json(tmp_path / "nope" / "report.json", {})
    assert err.value.filename == str(tmp_path / "nope")


def test_write_json_refuses_data_that_is_not_json(tmp_path: Path):
    path = tmp_path / "report.json"
    with pytest.raises(TypeError, match="not JSON serializable"):
        write_json(path, {"bad": object()})
    assert not path.exists()


def test_path_or_none_makes_paths_absolute(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    monkeypatch.chdir(tmp_path)
    assert path_or_none(None) is None
    assert path_or_none("a/b.csv") == str(tmp_path.resolve() / "a" / "b.csv")
    assert path_or_none(Path("/x/../y.csv")) == str(Path("/y.csv"))
