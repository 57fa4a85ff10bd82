"""Tests of :func:`terrain_odom.io.groundtruth.read_groundtruth`."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest

from terrain_odom.errors import InputFileError
from terrain_odom.io.groundtruth import GROUNDTRUTH_COLUMNS, read_groundtruth

TEXT = (
    "t,x,y,yaw,y_l,y_r,x_icr,terrain,alpha\n"
    "0,0,0,0,.4,-.4,0,grass,0.9\n"
    "0.1,0.1,0,0,.4,-.4,0,sand,0.9\n"
)


def test_reads_every_column_from_a_file(tmp_path: Path):
    path = tmp_path / "groundtruth.csv"
    path.write_text(TEXT.replace("alpha\n", "alpha,extra\n").replace("0.9\n", "0.9,ignored\n"))
    gt = read_groundtruth(path)
    assert gt.source == str(path) and len(gt) == 2
    np.testing.assert_array_equal(gt.t, [0.0, 0.1])
    np.testing.assert_array_equal(gt.pose, [[0, 0, 0], [0.1, 0, 0]])
    np.testing.assert_array_equal(gt.icr, [[0.4, -0.4, 0], [0.4, -0.4, 0]])
    assert gt.alpha.tolist() == [0.9, 0.9]
    assert gt.terrain.tolist() == ["grass", "sand"]
    assert gt.changes() == [(0.1, "grass", "sand")]


def test_alpha_is_optional():
    text = TEXT.replace(",alpha", "").replace(",0.9", "")
    assert read_groundtruth(io.StringIO(text)).alpha is None


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (TEXT.replace("0.1,0.1", "0.0,0.1"), r"line 3, column 't'.*does not increase"),
        (
            TEXT.replace(".4,-.4,0,grass", "nan,-.4,0,grass"),
            r"line 2, column 'y_l': 'nan' is not a finite number$",
        ),
        (TEXT.replace("0,0,0,0,.4", "0,abc,0,0,.4"), r"line 2, column 'x': 'abc' is not a finite"),
        ("t,x,y,yaw,y_l,y_r,x_icr\n0,0,0,0,1,-1,0\n", r"missing column 'terrain'"),
        (TEXT.replace("grass", " "), r"line 2, column 'terrain': empty terrain label$"),
        (TEXT.split("0.1,")[0], r"line 1: needs at least two rows of ground truth$"),
    ],
)
def test_bad_files_name_the_line_and_column(text: str, message: str):
    with pytest.raises(InputFileError, match=message):
        read_groundtruth(io.StringIO(text))


def test_required_columns_are_the_documented_ones():
    assert GROUNDTRUTH_COLUMNS == ("t", "x", "y", "yaw", "y_l", "y_r", "x_icr", "terrain")
    for column in GROUNDTRUTH_COLUMNS:
        header, *rows = TEXT.splitlines()
        keep = [i for i, c in enumerate(header.split(",")) if c != column]
        text = "\n".join(",".join(line.split(",")[i] for i in keep) for line in TEXT.splitlines())
        with pytest.raises(InputFileError, match=f"missing column '{column}'"):
            read_groundtruth(io.StringIO(text))
