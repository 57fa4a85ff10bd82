"""Tests of block writing: :meth:`TrajectoryWriter.write_block` and :class:`TrajectoryBlocks`."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrain_odom.io import TrajectoryWriter, read_trajectory_csv, write_tum
from terrain_odom.io.trajectory import (
    TrajectoryBlocks,
    TumWriter,
    _float_texts,
    trajectory_columns,
)

TRICKY_FLOATS = [0.1, 1.0 / 3.0, -2.5e-300, 1.7e9 + 0.123456789, 5e-324, 1e308, -0.0, np.inf]
LABELS = ["grass", "asphalt, wet", 'say "hi"', " padded ", "", "two\nlines", "é", "gravel"]
COLUMNS = ["t", "x", "segment", "terrain", "f32"]


def _rows() -> list[dict]:
    x = np.array(TRICKY_FLOATS)
    x[2] = np.nan
    return [
        {
            "t": 0.05 * k,
            "x": x[k],
            "segment": np.int64(k // 3),
            "terrain": LABELS[k],
            "f32": np.float32(k / 7),
        }
        for k in range(len(LABELS))
    ]


def test_a_block_writes_the_bytes_of_its_rows_written_one_by_one(tmp_path: Path) -> None:
    rows = _rows()
    one, block = tmp_path / "rows.csv", tmp_path / "block.csv"
    with TrajectoryWriter(one, COLUMNS) as writer:
        for row in rows:
            writer.write(row)
    with TrajectoryWriter(block, COLUMNS) as writer:
        writer.write_block(
            {
                "t": np.array([r["t"] for r in rows]),
                "x": np.array([r["x"] for r in rows]),
                "segment": np.array([r["segment"] for r in rows]),
                "terrain": [r["terrain"] for r in rows],
                "f32": np.array([r["f32"] for r in rows], dtype=np.float32),
            }
        )
    assert block.read_bytes() == one.read_bytes()
    back = read_trajectory_csv(block)
    assert back["x"][0] == 0.1 and np.isnan(back["x"][2]) and back["x"][7] == np.inf
    assert back["terrain"].tolist()[1:6] == ["asphalt, wet", 'say "hi"', "padded", "", "two\nlines"]


@pytest.mark.parametrize(
    ("block", "error", "match"),
    [
        (
            {"t": [0.0], "x": [1.0, 2.0], "segment": [0], "terrain": ["a"], "f32": [0.0]},
            ValueError,
            "length",
        ),
        ({"t": [0.0]}, ValueError, "missing"),
        (
            {"t": [True], "x": [1.0], "segment": [0], "terrain": ["a"], "f32": [0.0]},
            TypeError,
            "bool",
        ),
        (
            {"t": [None], "x": [1.0], "segment": [0], "terrain": ["a"], "f32": [0.0]},
            TypeError,
            "None",
        ),
        (
            {"t": [[0.0]], "x": [1.0], "segment": [0], "terrain": ["a"], "f32": [0.0]},
            ValueError,
            "1-D",
        ),
    ],
)
def test_write_block_rejects_bad_blocks(
    tmp_path: Path, block: dict, error: type, match: str
) -> None:
    with TrajectoryWriter(tmp_path / "t.csv", COLUMNS) as writer, pytest.raises(error, match=match):
        writer.write_block(block)


def test_blocks_write_the_rows_of_row_by_row_writing_and_their_tum(tmp_path: Path) -> None:
    """Blocks (of 3 and 4 rows) give the file of rows written one by one, and write_tum's file."""
    names = ("x", "y", "yaw", "y_l", "y_r", "x_icr", "alpha")
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(0.01, 0.1, 7))
    states, stds = rng.normal(size=(7, 7)), rng.normal(size=(7, 7)) ** 2
    stds[:, :3] = np.nan
    terrain = np.array(["grass"] * 4 + ["gravel"] * 3, dtype=object)
    path, reference = tmp_path / "blocks.csv", tmp_path / "rows.csv"
    tum_path, tum_reference = tmp_path / "blocks.tum", tmp_path / "whole.tum"
    with (
        TrajectoryWriter(path, trajectory_columns(names), flush_rows=1) as writer,
        TumWriter(tum_path) as tum,
    ):
        blocks = TrajectoryBlocks(writer, names, tum)
        for rows in (slice(0, 3), slice(3, 7)):
            blocks.write(t[rows], states[rows], stds[rows], terrain[rows])
            assert len(path.read_text().splitlines()) == 1 + rows.stop  # on disk at once
        assert not tum_path.exists()  # in place only when closed
    with TrajectoryWriter(reference, trajectory_columns(names)) as writer:
        for k in range(7):
            row = {"t": t[k], "terrain": terrain[k]}
            row.update(zip(names, states[k], strict=True))
            row.update((f"std_{n}", s) for n, s in zip(names, stds[k], strict=True))
            writer.write(row)
    assert path.read_bytes() == reference.read_bytes()
    write_tum(tum_reference, t, *states[:, :3].T)
    assert tum_path.read_bytes() == tum_reference.read_bytes()


def test_a_discarded_tum_writer_leaves_no_file(tmp_path: Path) -> None:
    """An interrupted run: the TUM file is neither written nor left half-written."""
    path = tmp_path / "t.tum"
    path.write_text("an earlier file\n")
    with TumWriter(path) as tum:
        tum.write(np.array([0.1]), np.array([1.0]), np.array([2.0]), np.array([0.5]))
        tum.discard()
    assert path.read_text() == "an earlier file\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.tum"]  # no temporary left


def test_a_non_finite_pose_reaches_neither_file(tmp_path: Path) -> None:
    names = ("x", "y", "yaw", "y_l", "y_r", "x_icr")
    states = np.zeros((2, 6))
    states[1, 0] = np.nan
    with (
        TrajectoryWriter(tmp_path / "t.csv", trajectory_columns(names)) as writer,
        TumWriter(tmp_path / "t.tum") as tum,
    ):
        with pytest.raises(ValueError, match=r"x\[1\] is nan"):
            TrajectoryBlocks(writer, names, tum).write(np.arange(2.0), states, states, ["a", "a"])
        tum.discard()
    assert len((tmp_path / "t.csv").read_text().splitlines()) == 1  # the header alone
    assert not (tmp_path / "t.tum").exists()


def test_a_one_column_block_keeps_empty_cells(tmp_path: Path) -> None:
    """A lone empty cell is quoted (an empty line would be skipped on reading)."""
    path = tmp_path / "one.csv"
    with TrajectoryWriter(path, ["terrain"]) as writer:
        writer.write_block({"terrain": ["a", "", "b"]})
    assert read_trajectory_csv(path)["terrain"].tolist() == ["a", "", "b"]


def test_write_tum_over_several_blocks_writes_every_row(tmp_path: Path) -> None:
    """10 000 rows (three blocks): each line is the row's values by repr, in order."""
    rng = np.random.default_rng(2)
    t, x, y, yaw = np.cumsum(rng.uniform(0.01, 0.1, 10000)), *rng.normal(size=(3, 10000))
    path = tmp_path / "t.tum"
    write_tum(path, t, x, y, yaw)
    lines = path.read_text().splitlines()
    assert len(lines) == 10001
    for k in (0, 4095, 4096, 9999):
        half = 0.5 * yaw[k]
        values = [t[k], x[k], y[k], 0.0, 0.0, 0.0, np.sin(half), np.cos(half)]
        assert lines[k + 1] == " ".join(repr(float(v)) for v in values)


@settings(max_examples=300, deadline=None)
@given(
    st.lists(
        st.floats(allow_nan=True, allow_infinity=True, allow_subnormal=True),
        min_size=1,
        max_size=40,
    )
)
def test_floats_are_written_exactly_whatever_their_magnitude(values: list[float]) -> None:
    """Every float's text reads back to the same float (sign of zero included); NaN is empty."""
    cells = _float_texts(np.array(values))
    assert len(cells) == len(values)
    for value, cell in zip(values, cells, strict=True):
        if np.isnan(value):
            assert cell == ""
        else:
            back = float(cell)
            assert back == value and np.signbit(back) == np.signbit(value), (value, cell)
            assert len(cell) <= len(repr(value)) + 8  # no padding digits: at most the notation


def test_a_block_writes_what_row_by_row_writing_writes_for_extreme_floats(tmp_path: Path) -> None:
    """Subnormals, huge values, negative zero, infinities: the same text either way."""
    floats = np.array([5e-324, -2.5e-300, 1.7976931348623157e308, -0.0, np.inf, -np.inf, 4.35e-7])
    rows, block = tmp_path / "rows.csv", tmp_path / "block.csv"
    with TrajectoryWriter(rows, ["x"]) as writer:
        for value in floats:
            writer.write({"x": value})
    with TrajectoryWriter(block, ["x"]) as writer:
        writer.write_block({"x": floats})
    assert rows.read_bytes() == block.read_bytes()
    assert read_trajectory_csv(block)["x"].tolist() == floats.tolist()
