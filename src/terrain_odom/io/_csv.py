"""Shared CSV reading for the file formats of terrain-odom.

Reads a whole CSV file with a header into raw cells while remembering the file
line of every record, so that readers can convert columns in bulk and still
report the first bad cell as ``file, line N, column 'c': problem``.
"""

from __future__ import annotations

import csv
import gc
import io
import itertools
import os
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from operator import itemgetter
from typing import TextIO

import numpy as np

from terrain_odom.errors import InputFileError

Source = str | os.PathLike[str] | TextIO
"""A file path, or an open text handle (e.g. :class:`io.StringIO`)."""

_MAX_SHOWN_CHARS = 40
_EMPTY_AS_NAN = {"": "nan"}


@dataclass(frozen=True)
class CsvTable:
    """The raw cells of a CSV file with a header, for conversion and messages.

    Attributes
    ----------
    name : str
        File name used in messages.
    header : list of str, shape (C,)
        Column names, stripped of surrounding whitespace.
    rows : list of list of str, shape (N, C)
        Data rows, unstripped cells; every row has exactly C cells.
    lines : sequence of int, shape (N,)
        1-based file line on which each data row starts.
    """

    name: str
    header: list[str]
    rows: list[list[str]]
    lines: Sequence[int]

    def __len__(self) -> int:
        return len(self.rows)

    @property
    def header_text(self) -> str:
        """The header as one shortened, quoted string for messages."""
        return shown(",".join(self.header))

    def error(
        self, message: str, *, row: int | None = None, column: str | None = None
    ) -> InputFileError:
        """Build the one-line error about data row ``row`` (the header if None) and ``column``."""
        line = 1 if row is None else self.lines[row]
        where = f"{self.name}, line {line}" + ("" if column is None else f", column {column!r}")
        return InputFileError(f"{where}: {message}")

    def cells(self, column: str) -> list[str]:
        """Unstripped cells of ``column``, one per data row."""
        return list(map(itemgetter(self.header.index(column)), self.rows))

    def convert(
        self,
        column: str,
        parse: Callable[[str], object],
        dtype: type[np.generic],
        complaint: Callable[[str], str],
    ) -> np.ndarray:
        """Convert every cell of ``column`` with ``parse`` into an array of ``dtype``.

        The fast path converts the whole column at once; only if it fails is
        the column walked again to find the first bad cell, which is reported
        with ``complaint(cell)``.
        """
        cells = self.cells(column)
        try:
            return np.fromiter(map(parse, cells), dtype=dtype, count=len(cells))
        except (ValueError, OverflowError):
            for row, cell in enumerate(cells):
                if not _converts(cell, parse, dtype):
                    raise self.error(complaint(cell), row=row, column=column) from None
            raise

    def require_columns(self, *columns: str, reason: str) -> None:
        """Raise if any of ``columns`` is missing from the header; ``reason`` says why needed."""
        for column in columns:
            if column not in self.header:
                raise self.error(
                    f"missing column {column!r} ({reason}); header is {self.header_text}"
                )


def read_csv(source: Source) -> CsvTable:
    """Read all records of a CSV file with a header; empty lines are skipped.

    Raises
    ------
    InputFileError
        If the file cannot be read, is empty, or a row's cell count differs
        from the header's.
    """
    (table,) = read_csv_chunks(source)
    return table


def read_csv_chunks(source: Source, size: int | None = None) -> Iterator[CsvTable]:
    """Read a CSV file with a header as tables of at most ``size`` data rows (all if None).

    Every table has the header and the file lines of its rows; at least one
    table is yielded (without rows if the file has none). A reader converting
    each table before the next is read holds one table's cells at a time,
    not the whole file's. A file with empty lines or multi-line records is
    read at once: the rows not yet yielded come as one last table.

    Raises
    ------
    InputFileError
        As :func:`read_csv` (for a table's cell counts, when it is reached).
    """
    with _open_text(source) as (handle, name):
        try:
            for header, rows, lines in _chunks(handle, size):
                table = CsvTable(name, [cell.strip() for cell in header], rows, lines)
                _check_ragged(table)
                yield table
        except UnicodeDecodeError as exc:
            raise InputFileError(f"{name}: not a UTF-8 text file ({exc.reason})") from None
        except csv.Error as exc:
            raise InputFileError(f"{name}: not a valid CSV file ({exc})") from None
        except _EmptyFile:
            raise InputFileError(
                f"{name}: file is empty; expected a header line naming the columns"
            ) from None


class _EmptyFile(Exception):
    """The file has no record at all."""


_Chunk = tuple[list[str], list[list[str]], Sequence[int]]


def _chunks(handle: TextIO, size: int | None) -> Iterator[_Chunk]:
    """Yield ``header, rows, lines`` of at most ``size`` rows each (:func:`read_csv_chunks`).

    The common case, one record per line and no empty line, is parsed without
    per-row Python code; at the first chunk breaking it the text is parsed
    again from the start while tracking line numbers (:func:`_records`), and
    the records not yet yielded come at once. A file is parsed where it lies
    (a second pass seeks back), so its whole text is never held beside its cells.
    """
    source = handle if handle.seekable() else io.StringIO(handle.read(), newline="")
    start = source.tell()
    reader = csv.reader(source)
    header = next(reader, [])
    done = 1 if header and reader.line_num == 1 else 0  # records read, all simple
    first = True
    while done:
        with collector_paused():
            rows = list(itertools.islice(reader, size))
        if reader.line_num != done + len(rows) or not all(rows):
            break
        if rows or first:
            yield header, rows, range(done + 1, done + 1 + len(rows))
        first, done = False, done + len(rows)
        if size is None or len(rows) < size:
            return
    source.seek(start)
    with collector_paused():
        records, lines = _records(source)
    if not records:
        raise _EmptyFile
    skip = max(done, 1)
    yield records[0], records[skip:], lines[skip:]


@contextmanager
def collector_paused() -> Iterator[None]:
    """Pause Python's cyclic garbage collector in the block (reference counting still frees).

    Parsing or writing a long table makes a list or tuple per row, none in a
    cycle; in a process holding many objects the collector's passes over
    them cost more than the parsing (a tenth of a 163k-row run, more under
    pytest). The previous state is restored on leaving.
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


@contextmanager
def _open_text(source: Source) -> Iterator[tuple[TextIO, str]]:
    """Yield a text handle on ``source`` and its name for messages."""
    if not isinstance(source, (str, os.PathLike)):
        name = getattr(source, "name", None)
        yield source, name if isinstance(name, str) else "<stream>"
        return
    name = os.fspath(source)
    try:
        handle = open(source, encoding="utf-8-sig", newline="")
    except FileNotFoundError:
        raise InputFileError(f"{name}: file does not exist") from None
    except OSError as exc:
        raise InputFileError(f"{name}: cannot open ({exc.strerror or exc})") from None
    with handle:
        yield handle, name


def _records(source: TextIO) -> tuple[list[list[str]], Sequence[int]]:
    """Non-empty CSV records of ``source`` and the 1-based file line each starts on."""
    reader = csv.reader(source)
    rows, lines = [], []
    start = 1
    for row in reader:
        if row:
            rows.append(row)
            lines.append(start)
        start = reader.line_num + 1
    return rows, lines


def _check_ragged(table: CsvTable) -> None:
    """Raise on the first data row whose cell count differs from the header's."""
    n_columns = len(table.header)
    lengths = np.fromiter(map(len, table.rows), dtype=np.intp, count=len(table))
    bad = np.flatnonzero(lengths != n_columns)
    if bad.size == 0:
        return
    row = int(bad[0])
    found = int(lengths[row])
    column = table.header[found] if found < n_columns else None  # first missing cell, if any
    message = f"row has {found} cells but the header has {n_columns}"
    raise table.error(message, row=row, column=column)


def _converts(cell: str, parse: Callable[[str], object], dtype: type[np.generic]) -> bool:
    """Whether ``parse(cell)`` succeeds and fits in ``dtype``."""
    try:
        np.asarray(parse(cell), dtype=dtype)
    except (ValueError, OverflowError):
        return False
    return True


def floats_or_nan(cells: list[str]) -> np.ndarray:
    """Cells as float64, exactly-empty ones as NaN; ValueError if another cell is no number."""
    return np.fromiter(map(float, map(_EMPTY_AS_NAN.get, cells, cells)), np.float64, len(cells))


def shown(text: str) -> str:
    """``repr`` of ``text`` shortened for a one-line message."""
    if len(text) > _MAX_SHOWN_CHARS:
        text = text[: _MAX_SHOWN_CHARS - 3] + "..."
    return repr(text)
