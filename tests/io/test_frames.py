"""Tests of :mod:`terrain_odom.io.frames`."""

from __future__ import annotations

import pytest

from terrain_odom.errors import InputFileError
from terrain_odom.io.frames import read_frames


def test_frames_csv_is_read_in_time_order(tmp_path):
    (tmp_path / "frames.csv").write_text("t,file\n1.0,b.png\n0.5, a.png\n1.0,c.png\n")
    frames = read_frames(tmp_path)
    assert frames.t.tolist() == [0.5, 1.0, 1.0]
    assert frames.files == [tmp_path / "a.png", tmp_path / "b.png", tmp_path / "c.png"]
    assert len(frames) == 3 and frames.source.endswith("frames.csv")


@pytest.mark.parametrize(
    ("text", "where"),
    [
        ("t,file\n0.0,a.png\nsoon,b.png\n", "line 3, column 't'"),
        ("t,file\n0.0,a.png\nnan,b.png\n", "line 3, column 't'"),
        ("t,file\n0.0,a.png\n0.1,  \n", "line 3, column 'file'"),
        ("t,file\n0.0,a.png\n0.1\n", "line 3, column 'file'"),
        ("time,file\n0.0,a.png\n", "line 1: missing column 't'"),
    ],
)
def test_malformed_frames_csv_names_line_and_column(tmp_path, text, where):
    (tmp_path / "frames.csv").write_text(text)
    with pytest.raises(InputFileError) as info:
        read_frames(tmp_path)
    message = str(info.value)
    assert "\n" not in message and message.startswith(str(tmp_path / "frames.csv"))
    assert where in message


def test_without_frames_csv_names_are_timestamps(tmp_path):
    for name in ("2.5.png", "0.25.jpg", "10.png", "notes.txt"):
        (tmp_path / name).write_bytes(b"")
    frames = read_frames(tmp_path)
    assert frames.t.tolist() == [0.25, 2.5, 10.0]
    assert [p.name for p in frames.files] == ["0.25.jpg", "2.5.png", "10.png"]


def test_without_frames_csv_other_names_are_an_error(tmp_path):
    for name in ("0.5.png", "frame_0001.png"):
        (tmp_path / name).write_bytes(b"")
    with pytest.raises(InputFileError, match=r"frame_0001\.png: without frames\.csv"):
        read_frames(tmp_path)


def test_missing_or_empty_folder(tmp_path):
    with pytest.raises(InputFileError, match="must be a folder"):
        read_frames(tmp_path / "nope")
    with pytest.raises(InputFileError, match="no frames.csv and no image files"):
        read_frames(tmp_path)
