"""Writing and reading estimated trajectories.

Two formats:

* a CSV file with a header (any columns, e.g. ``t,x,y,yaw,terrain``), streamed
  by :class:`TrajectoryWriter` (a row, or a block of rows given column by
  column) so that an interrupted run keeps the rows it computed, and read back
  by :func:`read_trajectory_csv`;
* the TUM format (``timestamp tx ty tz qx qy qz qw``, space separated) of the
  trajectory-evaluation tools (e.g. ``evo``), written by :func:`write_tum`.

Floats are written exactly: the shortest digits that read back to the same
float (Ryu's, formatted by ``orjson`` in C, ~5x faster than ``repr``; the
notation can differ from ``repr``: ``0.00001`` for ``1e-05``); NaN is
written as an empty cell, as in the wheel-log format, infinities as
``inf``/``-inf``.
"""

from __future__ import annotations

import contextlib
import csv
import io
import numbers
import os
import time
from collections.abc import Mapping, Sequence
from itertools import repeat
from types import TracebackType
from typing import NoReturn

import numpy as np
import orjson

from terrain_odom.io._csv import CsvTable, collector_paused, floats_or_nan, read_csv
from terrain_odom.io.atomic import AtomicFile, OutputFileError

__all__ = [
    "TrajectoryBlocks",
    "TrajectoryWriter",
    "TumWriter",
    "read_trajectory_csv",
    "trajectory_columns",
    "write_tum",
]

StrPath = str | os.PathLike[str]
"""A file path."""

_BLOCK_ROWS = 4096
"""Rows formatted at once by :func:`write_tum`."""

Cell = str | float | np.floating | np.integer
"""A value of one CSV cell: text, or a real number (Python or numpy)."""


class TrajectoryWriter:
    r"""Stream a CSV trajectory to disk, one row at a time.

    The header is written on opening. Rows are flushed to the operating system
    (and synced to disk) when ``flush_rows`` rows are pending or when
    ``flush_seconds`` of wall time have passed since the last flush (checked at
    each write), and on :meth:`close`; so when a run is interrupted, the file
    holds every row up to the last flush.

    Parameters
    ----------
    path : str or os.PathLike
        Output file; created or overwritten. Its directory must exist.
    columns : sequence of str, shape (C,)
        Column names, unique and non-empty, in file order.
    flush_rows : int, optional
        Flush once this many rows are pending (default 1000).
    flush_seconds : float, optional
        Flush at the first write this long after the last flush, s (default 1).

    Raises
    ------
    ValueError
        If ``columns`` is empty, has an empty or repeated name, or the flush
        settings are not positive.
    OSError
        If the file cannot be created.

    Notes
    -----
    Cell values: a ``str`` is written as is (quoted by the CSV rules if
    needed); an integer as an integer; any other real number with
    its exact text (see the module's docstring), except NaN, written as
    an empty cell.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = tempfile.TemporaryDirectory()
    >>> path = pathlib.Path(folder.name) / "trajectory.csv"
    >>> with TrajectoryWriter(path, ["t", "x", "terrain"]) as writer:
    ...     writer.write({"t": 0.1, "x": float("nan"), "terrain": "grass"})
    >>> path.read_text()
    't,x,terrain\n0.1,,grass\n'
    >>> folder.cleanup()
    """

    def __init__(
        self,
        path: StrPath,
        columns: Sequence[str],
        *,
        flush_rows: int = 1000,
        flush_seconds: float = 1.0,
    ) -> None:
        self._columns = _checked_columns(columns)
        self._column_set = frozenset(self._columns)
        if flush_rows < 1 or not flush_seconds > 0:
            raise ValueError(
                f"need flush_rows >= 1 and flush_seconds > 0, got {flush_rows}, {flush_seconds}"
            )
        self._flush_rows = flush_rows
        self._flush_seconds = flush_seconds
        self._path = os.fspath(path)
        try:
            self._fd: int | None = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o666)
        except OSError as exc:
            raise OutputFileError(exc.errno, exc.strerror, self._path) from None
        self._whole = 0  # bytes on disk, ending with a whole row
        self._rows = 0  # rows on disk
        self._buffer = io.StringIO(newline="")  # rows not yet written
        self._csv = csv.writer(self._buffer, lineterminator="\n")
        self._csv.writerow(self._columns)
        self._pending = 0
        self.flush()

    @property
    def columns(self) -> tuple[str, ...]:
        """Column names, in file order."""
        return self._columns

    @property
    def rows_written(self) -> int:
        """Rows on disk (flushed), not counting the header."""
        return self._rows

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` has been called."""
        return self._fd is None

    def write(self, row: Mapping[str, Cell]) -> None:
        """Append one row.

        Parameters
        ----------
        row : mapping of str to str or real number
            One value per column; its keys must be exactly :attr:`columns`.

        Raises
        ------
        ValueError
            If the writer is closed or the keys differ from the columns.
        TypeError
            If a value is neither a str nor a real number.
        """
        self._check_keys(row)
        self._csv.writerow([_format_cell(row[column]) for column in self._columns])
        self._written(1)

    def write_block(self, block: Mapping[str, np.ndarray | Sequence[Cell]]) -> None:
        """Append a block of rows given column by column (the fast way to stream many rows).

        Each column is formatted at once (floats exactly, NaN empty, as
        :meth:`write`): a 22-column row costs about 3 us, against ~27 us
        through :meth:`write`.

        Parameters
        ----------
        block : mapping of str to array_like, each of shape (B,)
            One sequence per column, all of one length; its keys must be
            exactly :attr:`columns`.

        Raises
        ------
        ValueError
            If the writer is closed, the keys differ from the columns or the
            lengths differ.
        TypeError
            If a value is neither a str nor a real number.
        """
        self._check_keys(block)
        self._write_columns([_format_column(block[column]) for column in self._columns])

    def write_cells(self, block: Mapping[str, list[str]]) -> None:
        """Append a block of rows given as the cells' text, column by column.

        The cells are written as they are (see :meth:`write_block`, which
        formats them first).

        Raises
        ------
        ValueError
            If the writer is closed, the keys differ from the columns or the
            lengths differ.
        """
        self._check_keys(block)
        self._write_columns([block[column] for column in self._columns])

    def _write_columns(self, cells: list[list[str]]) -> None:
        """Write the cells' text given column by column, in file order (keys checked)."""
        lengths = {len(column) for column in cells}
        if len(lengths) > 1:
            raise ValueError(f"columns of a block differ in length: {sorted(lengths)}")
        rows = lengths.pop() if lengths else 0
        with collector_paused():  # a tuple per row
            if len(cells) == 1:  # a lone empty cell must be quoted: the csv module's rules
                self._csv.writerows(zip(*cells, strict=True))
            elif rows:  # the csv module's writer costs ~6 us a row; joining ~1 us
                self._buffer.write("\n".join(map(",".join, zip(*cells, strict=True))) + "\n")
        self._written(rows)

    def _check_keys(self, row: Mapping[str, object]) -> None:
        """Refuse a closed writer or keys that are not exactly the columns."""
        if self.closed:
            raise ValueError("write to a closed TrajectoryWriter")
        if row.keys() != self._column_set:
            missing = [c for c in self._columns if c not in row]
            unknown = [k for k in row if k not in self._column_set]
            raise ValueError(f"row keys differ from columns: missing {missing}, extra {unknown}")

    def _written(self, rows: int) -> None:
        """Count ``rows`` more pending rows; flush if the row or time limit is reached."""
        self._pending += rows
        if (
            self._pending >= self._flush_rows
            or time.monotonic() - self._last_flush >= self._flush_seconds
        ):
            self.flush()

    def flush(self) -> None:
        """Push every written row to the operating system and sync it to disk.

        Raises
        ------
        OutputFileError
            The file cannot be written (a full disk ...): it is cut back to
            its last whole row and closed.
        """
        if self._fd is None:
            return
        data = self._buffer.getvalue().encode("utf-8")
        self._buffer.seek(0)
        self._buffer.truncate()
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(self._fd, view) :]
            os.fsync(self._fd)
        except OSError as exc:
            self._fail(exc)
        self._whole += len(data)
        self._rows += self._pending
        self._pending = 0
        self._last_flush = time.monotonic()

    def close(self) -> None:
        """Flush and close the file; closing again does nothing."""
        if self._fd is not None:
            self.flush()
            os.close(self._fd)
            self._fd = None

    def _fail(self, exc: OSError) -> NoReturn:
        """Cut the file back to its last whole row, close it, raise naming the file."""
        assert self._fd is not None
        with contextlib.suppress(OSError):
            os.ftruncate(self._fd, self._whole)
        os.close(self._fd)
        self._fd = None
        raise OutputFileError(exc.errno, exc.strerror, self._path) from None

    def __enter__(self) -> TrajectoryWriter:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()


class TrajectoryBlocks:
    """Blocks of a filter run (``t``, states, stds, terrain) into ``trajectory.csv`` and a TUM file.

    Each block is formatted column by column and written at once
    (:meth:`TrajectoryWriter.write_block`); with a :class:`TumWriter`, the
    same block's TUM lines are written from the same text of ``t, x, y``
    (formatted once for both files).

    Parameters
    ----------
    writer : TrajectoryWriter
        Opened with :func:`trajectory_columns` of ``names``.
    names : tuple of str, shape (n,)
        State names, in the column order of the states given to :meth:`write`
        (``x, y, yaw`` first for a TUM file).
    tum : TumWriter, optional
        Also write the pose of every row in the TUM format.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = tempfile.TemporaryDirectory()
    >>> path = pathlib.Path(folder.name) / "trajectory.csv"
    >>> names = ("x", "y", "yaw", "y_l", "y_r", "x_icr")
    >>> with TrajectoryWriter(path, trajectory_columns(names)) as writer:
    ...     blocks = TrajectoryBlocks(writer, names)
    ...     blocks.write(np.array([0.5]), np.arange(6.0)[None], np.full((1, 6), np.nan), ["grass"])
    >>> path.read_text().splitlines()[1]
    '0.5,0.0,1.0,2.0,3.0,4.0,5.0,grass,,,,,,'
    >>> folder.cleanup()
    """

    def __init__(
        self, writer: TrajectoryWriter, names: tuple[str, ...], tum: TumWriter | None = None
    ) -> None:
        self._writer = writer
        self._names = names
        self._tum = tum

    def write(
        self,
        t: np.ndarray,
        states: np.ndarray,
        stds: np.ndarray,
        terrain: np.ndarray | Sequence[str],
    ) -> None:
        """Write a block of ``B`` rows: ``t`` (B,), ``states`` and ``stds`` (B, n), ``terrain`` (B,).

        Raises
        ------
        ValueError
            As :meth:`TrajectoryWriter.write_block`, or for the TUM file as
            :func:`write_tum` (a non-finite pose).
        """
        if self._tum is not None:
            _tum_columns(t, *states[:, :3].T)  # check before any file gets the block
        cells = {name: _format_column(states[:, k]) for k, name in enumerate(self._names)}
        cells["t"] = _format_column(t)
        cells["terrain"] = _format_column(np.asarray(terrain))
        cells.update(
            (f"std_{name}", _format_column(stds[:, k])) for k, name in enumerate(self._names)
        )
        self._writer.write_cells(cells)
        if self._tum is not None:
            self._tum.write_cells(cells["t"], cells["x"], cells["y"], states[:, 2])


class TumWriter(AtomicFile):
    """Stream a planar trajectory in the TUM format, block by block; atomic on close.

    The lines go to a temporary file that replaces ``path`` when the writer
    is closed without an error (:class:`~terrain_odom.io.atomic.AtomicFile`,
    also for :meth:`~terrain_odom.io.atomic.AtomicFile.discard`): an
    interrupted run leaves no partial TUM file. See :func:`write_tum` for
    the format.

    Parameters
    ----------
    path : str or os.PathLike
        Output file; created or replaced. Its directory must exist.
    """

    def __init__(self, path: StrPath) -> None:
        super().__init__(path)
        self.write_bytes(b"# timestamp tx ty tz qx qy qz qw\n")

    def write(self, t: np.ndarray, x: np.ndarray, y: np.ndarray, yaw: np.ndarray) -> None:
        """Append rows (1-D arrays of one length: s, m, m, rad); ``ValueError`` if not finite."""
        t, x, y, yaw = _tum_columns(t, x, y, yaw)
        self.write_cells(_float_texts(t), _float_texts(x), _float_texts(y), yaw)

    def write_cells(self, t: list[str], x: list[str], y: list[str], yaw: np.ndarray) -> None:
        """Append rows whose ``t, x, y`` are already text (exact, finite); ``yaw`` in rad."""
        half = 0.5 * np.asarray(yaw, dtype=np.float64)
        qz, qw = _float_texts(np.sin(half)), _float_texts(np.cos(half))
        level = repeat("0.0 0.0 0.0", len(t))  # z, qx, qy
        with collector_paused():  # a tuple per row
            lines = map(" ".join, zip(t, x, y, level, qz, qw, strict=True))
            self.write_bytes("".join(line + "\n" for line in lines).encode("ascii"))


def read_trajectory_csv(path: StrPath) -> dict[str, np.ndarray]:
    """Read a CSV trajectory such as one written by :class:`TrajectoryWriter`.

    Parameters
    ----------
    path : str or os.PathLike
        CSV file with a header row.

    Returns
    -------
    dict of str to ndarray, each of shape (N,)
        One array per column, in file order. A column whose non-empty cells are
        all numbers is float64 with NaN for empty cells; any other column is a
        str array of the stripped cells. A file with only a header gives empty
        float64 arrays.

    Raises
    ------
    InputFileError
        If the file is missing, unreadable or empty, a column name is empty or
        repeated, or a row has the wrong number of cells; the one-line message
        names the file, line and column.
    """
    table = read_csv(path)
    for index, column in enumerate(table.header):
        if not column:
            raise table.error(f"column {index + 1} of the header has no name")
        if table.header.index(column) != index:
            raise table.error("column appears more than once in the header", column=column)
    return {column: _column_array(table, column) for column in table.header}


def write_tum(path: StrPath, t: np.ndarray, x: np.ndarray, y: np.ndarray, yaw: np.ndarray) -> None:
    """Write a planar trajectory in the TUM format, atomically.

    Each line is ``timestamp tx ty tz qx qy qz qw`` with ``tz = 0`` and the
    quaternion of a rotation by ``yaw`` about z. The text goes to a temporary
    file in the same directory, which then replaces ``path``, so readers never
    see a partial file.

    Parameters
    ----------
    path : str or os.PathLike
        Output file; created or replaced. Its directory must exist.
    t : ndarray, shape (N,)
        Timestamps, s.
    x, y : ndarray, shape (N,)
        Position, m.
    yaw : ndarray, shape (N,)
        Heading, rad, counter-clockwise.

    Raises
    ------
    ValueError
        If the arrays are not 1-D of one length or hold a non-finite value.
    OSError
        If the file cannot be written.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = tempfile.TemporaryDirectory()
    >>> path = pathlib.Path(folder.name) / "trajectory.tum"
    >>> write_tum(path, np.array([0.5]), np.array([1.0]), np.array([2.0]), np.array([np.pi]))
    >>> path.read_text().splitlines()[1]
    '0.5 1.0 2.0 0.0 0.0 0.0 1.0 6.123233995736766e-17'
    >>> folder.cleanup()
    """
    t, x, y, yaw = _tum_columns(t, x, y, yaw)  # check before the file is created
    with TumWriter(path) as writer:
        for start in range(0, t.size, _BLOCK_ROWS):
            block = slice(start, start + _BLOCK_ROWS)
            writer.write(t[block], x[block], y[block], yaw[block])


def _checked_columns(columns: Sequence[str]) -> tuple[str, ...]:
    """``columns`` as a tuple, after checking the names are non-empty and unique."""
    names = tuple(columns)
    if not names:
        raise ValueError("a trajectory needs at least one column")
    for name in names:
        if not isinstance(name, str) or not name.strip() or name != name.strip():
            raise ValueError(f"column names must be non-empty, unpadded strings: {name!r}")
        if names.count(name) > 1:
            raise ValueError(f"column {name!r} is given more than once")
    return names


def _format_cell(value: Cell) -> str:
    """Text of one CSV cell (see :class:`TrajectoryWriter`)."""
    if isinstance(value, str):
        return value
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        return str(int(value))
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        return _float_texts(np.array([float(value)]))[0]
    raise TypeError(f"cannot write {type(value).__name__} {value!r} to a trajectory cell")


def _float_texts(values: np.ndarray) -> list[str]:
    """Exact texts of floats (see the module's docstring): NaN empty, infinities ``inf``/``-inf``."""
    array = np.ascontiguousarray(values, dtype=np.float64)
    if not array.size:
        return []
    text = orjson.dumps(array, option=orjson.OPT_SERIALIZE_NUMPY).decode("ascii")
    cells = text[1:-1].replace("null", "").split(",")  # NaN and infinities are JSON nulls
    for index in np.flatnonzero(np.isinf(array)).tolist():
        cells[index] = repr(float(array[index]))
    return cells


def _format_column(values: np.ndarray | Sequence[Cell]) -> list[str]:
    """Texts of one column's cells (see :class:`TrajectoryWriter`), formatted at once."""
    array = np.asarray(values)
    if array.ndim != 1:
        raise ValueError(f"a block column must be 1-D, got shape {array.shape}")
    kind = array.dtype.kind
    if kind == "f":
        return _float_texts(array)
    if kind in "iu":
        return list(map(str, array.tolist()))
    texts = array.tolist() if kind == "U" else list(map(_format_cell, array.tolist()))
    quoted = {text: _quoted(text) for text in set(texts)}  # few distinct labels
    return list(map(quoted.__getitem__, texts))


def _quoted(text: str) -> str:
    """``text`` as a CSV cell, quoted (or not) exactly as the csv module's writer does."""
    buffer = io.StringIO()
    csv.writer(buffer, lineterminator="\n").writerow([text, ""])
    return buffer.getvalue()[:-2]  # without ",\n"


def _column_array(table: CsvTable, column: str) -> np.ndarray:
    """One column as float64 (NaN for empty cells) if all its cells are numbers, else str."""
    cells = [cell.strip() for cell in table.cells(column)]
    try:
        return floats_or_nan(cells)
    except ValueError:
        return np.array(cells, dtype=str)


def _tum_columns(
    t: np.ndarray, x: np.ndarray, y: np.ndarray, yaw: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``t, x, y, yaw`` as float64, after checking they are 1-D, of one length and finite."""
    arrays = {
        name: np.asarray(values, dtype=np.float64)
        for name, values in (("t", t), ("x", x), ("y", y), ("yaw", yaw))
    }
    shape = arrays["t"].shape
    for name, array in arrays.items():
        if array.ndim != 1 or array.shape != shape:
            raise ValueError(
                f"t, x, y, yaw must be 1-D of one length; {name} has shape {array.shape}, "
                f"t has {shape}"
            )
        bad = np.flatnonzero(~np.isfinite(array))
        if bad.size:
            raise ValueError(f"{name}[{bad[0]}] is {array[bad[0]]}, not a finite number")
    return arrays["t"], arrays["x"], arrays["y"], arrays["yaw"]


def trajectory_columns(names: tuple[str, ...]) -> list[str]:
    """Column order of ``trajectory.csv`` for a filter with these states."""
    extra = [n for n in names if n not in ("x", "y", "yaw", "y_l", "y_r", "x_icr")]
    return (
        ["t", "x", "y", "yaw", "y_l", "y_r", "x_icr", "terrain"]
        + extra
        + [f"std_{n}" for n in names]
    )
