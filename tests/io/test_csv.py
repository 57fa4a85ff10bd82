"""Tests of the shared CSV reader :mod:`terrain_odom.io._csv`."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest

from terrain_odom.errors import InputFileError
from terrain_odom.io._csv import floats_or_nan, read_csv, read_csv_chunks, shown


def _table(text: str):
    return read_csv(io.StringIO(text))


def test_reads_header_rows_and_file_lines_from_a_path(tmp_path: Path):
    path = tmp_path / "a.csv"
    path.write_text("\ufeff a , b \n1,2\n\n3,4\n", encoding="utf-8")  # BOM, blank line
    table = read_csv(path)
    assert table.name == str(path)
    assert table.header == ["a", "b"]
    assert table.rows == [["1", "2"], ["3", "4"]]
    assert list(table.lines) == [2, 4]
    assert len(table) == 2


def test_a_quoted_multi_line_cell_keeps_the_following_line_numbers():
    table = _table('a,b\n1,"x\ny"\n3,4\n')
    assert table.rows == [["1", "x\ny"], ["3", "4"]]
    assert list(table.lines) == [2, 4]


def test_a_stream_is_named_by_its_name_or_stream():
    assert _table("a\n1\n").name == "<stream>"
    handle = io.StringIO("a\n1\n")
    handle.name = "given.csv"
    assert read_csv(handle).name == "given.csv"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", r"^<stream>: file is empty; expected a header line"),
        ("a,b\n1,2\n3\n", r"^<stream>, line 3, column 'b': row has 1 cells but the header has 2$"),
        ("a,b\n1,2,3\n", r"^<stream>, line 2: row has 3 cells but the header has 2$"),
    ],
)
def test_bad_tables_name_the_line_and_column(text: str, message: str):
    with pytest.raises(InputFileError, match=message):
        _table(text)


def test_missing_and_binary_files(tmp_path: Path):
    missing = tmp_path / "nope.csv"
    with pytest.raises(InputFileError, match=r"nope\.csv: file does not exist$"):
        read_csv(missing)
    binary = tmp_path / "bad.csv"
    binary.write_bytes(b"a,b\n\xff,1\n")
    with pytest.raises(InputFileError, match=r"bad\.csv: not a UTF-8 text file"):
        read_csv(binary)
    with pytest.raises(InputFileError, match=r": cannot open"):
        read_csv(tmp_path)  # a folder


def test_convert_reports_the_first_bad_cell():
    table = _table("a\n1\n2\n\nx\n")
    np.testing.assert_array_equal(_table("a\n1\n2\n").convert("a", int, np.int64, str), [1, 2])
    with pytest.raises(InputFileError, match=r"^<stream>, line 5, column 'a': bad 'x'$"):
        table.convert("a", int, np.int64, lambda cell: f"bad {cell!r}")


def test_convert_reports_a_value_that_overflows_the_dtype():
    table = _table("a\n1\n99999999999999999999999\n")
    with pytest.raises(InputFileError, match=r"line 3, column 'a': too big"):
        table.convert("a", int, np.int64, lambda cell: "too big")


def test_require_columns_names_the_reason_and_the_header():
    table = _table("t,v\n0,1\n")
    table.require_columns("t", reason="time")
    with pytest.raises(
        InputFileError, match=r"^<stream>, line 1: missing column 'x' \(pose\); header is 't,v'$"
    ):
        table.require_columns("t", "x", reason="pose")


def test_cells_floats_or_nan_and_shown():
    table = _table("a,b\n 1 ,\n2,3\n")
    assert table.cells("a") == [" 1 ", "2"]
    np.testing.assert_array_equal(floats_or_nan(table.cells("b")), [np.nan, 3.0])
    with pytest.raises(ValueError):
        floats_or_nan(["1", "x"])
    assert shown("abc") == "'abc'"
    long = shown("x" * 50)
    assert long.endswith("...'") and len(long) == 42


class _Unseekable(io.StringIO):
    """A stream that cannot seek (a pipe, standard input)."""

    def seekable(self) -> bool:
        return False


@pytest.mark.parametrize(
    "text", ["t,v\n1,2\n3,4\n", 't,v\n\n1,"a\nb"\n\n3,4\n'], ids=["one-pass", "second-pass"]
)
def test_file_and_unseekable_stream_read_alike(tmp_path: Path, text: str):
    """Parsed in place (a file, seeking back for line numbers) or from its text: same table."""
    path = tmp_path / "t.csv"
    path.write_text(text, newline="")
    from_file, from_pipe = read_csv(path), read_csv(_Unseekable(text, newline=""))
    assert from_file.rows == from_pipe.rows and list(from_file.lines) == list(from_pipe.lines)
    assert list(from_file.lines) == ([2, 3] if text.count("\n") == 3 else [3, 6])


@pytest.mark.parametrize(
    "text",
    [
        "a,b\n1,2\n3,4\n5,6\n7,8\n9,10\n",  # simple lines: chunks of 2 rows
        "a,b\n1,2\n3,4\n\n5,6\n7,8\n\n9,10\n",  # an empty line in the third chunk
        'a,b\n1,2\n3,"x\ny"\n5,6\n',  # a multi-line record in the first chunk
        "\na,b\n1,2\n",  # an empty line before the header
        "a,b\n",  # header only: one table without rows
    ],
)
def test_chunks_hold_the_rows_and_lines_of_the_whole_read(text: str):
    whole = read_csv(io.StringIO(text))
    chunks = list(read_csv_chunks(io.StringIO(text), 2))
    assert all(c.header == whole.header for c in chunks)
    assert [r for c in chunks for r in c.rows] == whole.rows
    assert [n for c in chunks for n in c.lines] == list(whole.lines)
    assert all(len(c.rows) <= 2 for c in chunks[:-1]) and len(chunks) >= 1


def test_chunks_report_a_ragged_row_of_a_later_chunk_with_its_file_line():
    chunks = read_csv_chunks(io.StringIO("a,b\n1,2\n3,4\n5\n"), 2)
    assert len(next(chunks).rows) == 2
    with pytest.raises(InputFileError, match=r"line 4, column 'b': row has 1 cells"):
        next(chunks)
    with pytest.raises(InputFileError, match="file is empty"):
        list(read_csv_chunks(io.StringIO("\n\n"), 2))


def test_reading_and_writing_a_long_table_pause_the_garbage_collector(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Parsing and joining rows run no collector passes (dozens without the pause)."""
    import contextlib
    import gc

    from terrain_odom.io import TrajectoryWriter, _csv, read_wheel_log, trajectory

    path = tmp_path / "long.csv"
    rows = "".join(f"{0.01 * k:.2f},0.5,0.6,,,\n" for k in range(30_000))
    path.write_text("t,v_l,v_r,x,y,yaw\n" + rows)

    def passes() -> int:
        collections: list[int] = []

        def count(phase: str, info: dict) -> None:
            collections.append(phase == "start")

        gc.collect()
        gc.callbacks.append(count)
        try:
            log = read_wheel_log(path)
            with TrajectoryWriter(tmp_path / "out.csv", ["t", "v_l"]) as writer:
                writer.write_block({"t": log.t, "v_l": log.v_l})
        finally:
            gc.callbacks.remove(count)
        assert len(log) == 30_000 and gc.isenabled()
        return sum(collections)

    paused = passes()
    for module in (_csv, trajectory):
        monkeypatch.setattr(module, "collector_paused", contextlib.nullcontext)
    assert paused <= 3 < 20 < passes()


def test_collector_paused_restores_the_callers_state() -> None:
    import gc

    from terrain_odom.io._csv import collector_paused

    with pytest.raises(RuntimeError), collector_paused():
        assert not gc.isenabled()
        raise RuntimeError
    assert gc.isenabled()
    gc.disable()
    try:
        with collector_paused():
            pass
        assert not gc.isenabled()
    finally:
        gc.enable()
