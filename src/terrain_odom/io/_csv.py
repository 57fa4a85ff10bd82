"""Shared CSV reading for the file formats of terrain-odom.

Reads a whole CSV file with a header into raw cells while remembering the file
line of every record, so that readers can convert columns in bulk and still
report the first bad cell as ``file, line N, column 'c': problem``.
"""

from __future__ import annotations

import csv
import io
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
    with _open_text(source) as (handle, name):
        try:
            rows, lines = _records(handle)
        except UnicodeDecodeError as exc:
            raise InputFileError(f"{name}: not a UTF-8 text file ({exc.reason})") from None
        except csv.Error as exc:
            raise InputFileError(f"{name}: not a valid CSV file ({exc})") from None
    if not rows:
        raise InputFileError(f"{name}: file is empty; expected a header line naming the columns")
    header = [cell.strip() for cell in rows[0]]
    table = CsvTable(name=name, header=header, rows=rows[1:], lines=lines[1:])
    _check_ragged(table)
    return table


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


def _records(handle: TextIO) -> tuple[list[list[str]], Sequence[int]]:
    """Non-empty CSV records of ``handle`` and the 1-based file line each starts on.

    The common case, one record per line and no empty line, is parsed in one
    pass without per-row Python code; otherwise the text is parsed again while
    tracking line numbers. A file is parsed where it lies (a second pass seeks
    back), so its whole text is never held beside its cells.
    """
    source = handle if handle.seekable() else io.StringIO(handle.read(), newline="")
    start = source.tell()
    reader = csv.reader(source)
    rows = list(reader)
    if reader.line_num == len(rows) and all(rows):
        return rows, range(1, len(rows) + 1)
    source.seek(start)
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
