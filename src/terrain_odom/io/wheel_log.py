"""Reader and writer of wheel logs, the CSV input format of terrain-odom.

A wheel log is a comma-separated text file (UTF-8) whose first line is a header
naming the columns; every following non-empty line is one sample. Header names
and cells are stripped of surrounding whitespace; unknown columns are ignored.
The columns:

``t``
    Time, s. Finite, strictly increasing within a segment, with no gap longer
    than :data:`MAX_SEGMENT_GAP` (60 s) in it.
``v_l, v_r`` *or* ``omega_l, omega_r``
    Left/right track surface speeds, m/s, or wheel angular speeds, rad/s
    (multiplied by ``wheel_radius`` on read). Exactly one pair; every cell
    finite.
``x, y, yaw`` (optional)
    Measured pose, m, m, rad, in a fixed world frame. Either all three columns
    or ``yaw`` alone (heading-only sensor). A cell is empty (or ``nan``) on rows
    without a measurement; ``x`` and ``y`` are given or missing together, while
    ``yaw`` may be given alone. ``yaw`` is wrapped to (-pi, pi].
``terrain`` (optional)
    Non-empty terrain label per row.
``segment`` (optional, default 0)
    Integer id of the contiguous piece the row belongs to. Rows of a segment are
    consecutive; time may jump (or restart) between segments.

Every problem raises :class:`~terrain_odom.errors.InputFileError` with a
one-line message naming the file, the 1-based file line (header = line 1) and
the column, e.g. ``log.csv, line 17, column 'v_l': 'abc' is not a number``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from terrain_odom.io._csv import CsvTable, Source, floats_or_nan, read_csv_chunks, shown
from terrain_odom.io.atomic import write_text_atomic
from terrain_odom.kinematics.integration import wrap_angle
from terrain_odom.records import WheelLog, change_runs, run_starts

__all__ = ["read_wheel_log", "write_wheel_log"]


_SPEED_PAIRS = (("v_l", "v_r"), ("omega_l", "omega_r"))
_POSE_COLUMNS = ("x", "y", "yaw")
MAX_SEGMENT_GAP = 60.0
"""Longest time without wheel speeds within a segment, s: dead reckoning across a longer one is
no estimate (the covariance grows without bound); the log must start a new segment there."""
_KNOWN_COLUMNS = ("t", *_SPEED_PAIRS[0], *_SPEED_PAIRS[1], *_POSE_COLUMNS, "terrain", "segment")


def read_wheel_log(source: Source, *, wheel_radius: float | None = None) -> WheelLog:
    r"""Read a wheel log (see the module docstring for the format).

    Parameters
    ----------
    source : str, os.PathLike or text handle
        Path of the CSV file, or an open text handle positioned at the header.
    wheel_radius : float, optional
        Wheel radius, m. Required (> 0) when the log gives wheel angular speeds
        ``omega_l, omega_r``; ignored when it gives surface speeds ``v_l, v_r``.

    Returns
    -------
    WheelLog
        Float64 ``t``, ``v_l``, ``v_r`` of shape (N,) and ``pose`` of shape
        (N, 3) with NaN where not measured; ``terrain`` a str array or None;
        ``segment`` int64. ``source`` is the path as given, the handle's
        ``name``, or ``'<stream>'``.

    Raises
    ------
    InputFileError
        If the file is missing, unreadable, empty or breaks the format; the
        one-line message names the file, line and column.

    Examples
    --------
    >>> import io
    >>> log = read_wheel_log(io.StringIO("t,v_l,v_r,yaw\n0.0,1.0,1.2,\n0.1,1.0,1.2,3.5\n"))
    >>> log.v_r.tolist(), log.has_yaw.tolist()
    ([1.2, 1.2], [False, True])
    >>> round(float(log.pose[1, 2]), 4)  # wrapped to (-pi, pi]
    -2.7832
    """
    parts: list[_Columns] = []
    last: _Last | None = None
    seen: set[int] = set()
    for table in read_csv_chunks(source, _CHUNK_ROWS):
        if not parts:
            _check_known_columns_unique(table)
            table.require_columns("t", reason="time, s")
            speeds = _wheel_speed_columns(table, wheel_radius)
            pose_columns = _pose_columns(table)
        if not table.rows:
            continue
        part = _read_chunk(table, speeds, pose_columns, last, seen)
        parts.append(part)
        last = _Last(float(part.t[-1]), int(part.segment[-1]), table.lines[-1])
    if not parts:
        raise table.error("no data rows after the header")
    t, v_l, v_r, pose, terrain, segment = _joined(parts)
    if speeds == _SPEED_PAIRS[1]:
        v_l, v_r = v_l * wheel_radius, v_r * wheel_radius
    return WheelLog(t, v_l, v_r, pose, terrain, segment, source=table.name)


def _joined(parts: list[_Columns]) -> _Columns:
    """Join the chunks' columns, one column at a time (``parts`` is emptied).

    Each column's chunks are freed once it is joined, so the log is held
    about once, not twice, while it is put together.
    """
    pieces = {name: [getattr(part, name) for part in parts] for name in _Columns._fields}
    parts.clear()
    joined: dict[str, Any] = {}
    for name in _Columns._fields:
        chunks = pieces.pop(name)
        joined[name] = None if chunks[0] is None else np.concatenate(chunks)
    return _Columns(**joined)


_CHUNK_ROWS = 16384
"""Rows converted at a time: a chunk's raw cells (~600 B a row) are all the
reader holds beside the log's own arrays."""


class _Columns(NamedTuple):
    """The converted columns of one chunk of rows."""

    t: np.ndarray
    v_l: np.ndarray
    v_r: np.ndarray
    pose: np.ndarray
    terrain: np.ndarray | None
    segment: np.ndarray


class _Last(NamedTuple):
    """Time (s), segment and file line of the last row of the previous chunk."""

    t: float
    segment: int
    line: int


def _read_chunk(
    table: CsvTable,
    speeds: tuple[str, str],
    pose_columns: tuple[str, ...],
    last: _Last | None,
    seen: set[int],
) -> _Columns:
    """Convert and check one chunk of rows; ``last`` and ``seen`` carry the earlier chunks."""
    segment = _segments(table, last, seen)
    t = _times(table, segment, last)
    v_l, v_r = (_finite_floats(table, column) for column in speeds)
    return _Columns(t, v_l, v_r, _pose(table, pose_columns), _terrain(table), segment)


def write_wheel_log(path: str | os.PathLike[str], log: WheelLog) -> None:
    """Write a wheel log as CSV (``t,v_l,v_r,x,y,yaw[,terrain],segment``), atomically.

    ``t`` is written to 1 microsecond, speeds and poses to 1e-9 (m/s, m,
    rad); an unmeasured pose cell is empty. :func:`read_wheel_log` reads it
    back.

    Parameters
    ----------
    path : str or PathLike
        File to write (its folder must exist).
    log : WheelLog
        The log; ``terrain`` becomes a column when it is not None.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = tempfile.TemporaryDirectory()
    >>> path = pathlib.Path(folder.name) / "log.csv"
    >>> log = WheelLog(np.array([0.0, 0.1]), np.ones(2), np.ones(2),
    ...                np.array([[0.0, 0.0, 0.0], [np.nan, np.nan, 0.5]]), None, np.zeros(2, int))
    >>> write_wheel_log(path, log)
    >>> path.read_text().splitlines()[2]
    '0.100000,1.000000000,1.000000000,,,0.500000000,0'
    >>> folder.cleanup()
    """
    labels = log.terrain
    header = "t,v_l,v_r,x,y,yaw" + (",terrain" if labels is not None else "") + ",segment"
    lines = [header]
    for k in range(len(log)):
        pose = ",".join("" if np.isnan(v) else f"{v:.9f}" for v in log.pose[k])
        label = f",{labels[k]}" if labels is not None else ""
        lines.append(
            f"{log.t[k]:.6f},{log.v_l[k]:.9f},{log.v_r[k]:.9f},{pose}{label},{log.segment[k]}"
        )
    write_text_atomic(path, "\n".join(lines) + "\n")


def _check_known_columns_unique(table: CsvTable) -> None:
    """Raise if a column this reader uses appears more than once in the header."""
    for column in _KNOWN_COLUMNS:
        if table.header.count(column) > 1:
            raise table.error("column appears more than once in the header", column=column)


def _wheel_speed_columns(table: CsvTable, wheel_radius: float | None) -> tuple[str, str]:
    """Pick the wheel-speed column pair and check ``wheel_radius`` if it is needed."""
    present = [pair for pair in _SPEED_PAIRS if any(c in table.header for c in pair)]
    if not present:
        raise table.error(
            "missing wheel-speed columns; need 'v_l,v_r' (surface speed, m/s) "
            f"or 'omega_l,omega_r' (rad/s); header is {table.header_text}"
        )
    if len(present) > 1:
        raise table.error(
            "both 'v_l,v_r' and 'omega_l,omega_r' wheel-speed columns are present; "
            "keep only one pair"
        )
    pair = present[0]
    table.require_columns(*pair, reason=f"wheel speeds come as the pair {','.join(pair)}")
    if pair == _SPEED_PAIRS[1] and not (wheel_radius is not None and 0 < wheel_radius < math.inf):
        raise table.error(
            f"wheel speeds are angular (omega_l,omega_r, rad/s): a wheel radius > 0 m is "
            f"needed to convert them to surface speeds (got {wheel_radius})"
        )
    return pair


def _pose_columns(table: CsvTable) -> tuple[str, ...]:
    """Return the pose columns present: all of ``x, y, yaw``, ``yaw`` alone, or none."""
    present = tuple(c for c in _POSE_COLUMNS if c in table.header)
    if present in ((), ("yaw",), _POSE_COLUMNS):
        return present
    missing = [c for c in _POSE_COLUMNS if c not in present]
    raise table.error(
        f"missing column {missing[0]!r}: pose columns must be 'x,y,yaw', 'yaw' alone, "
        f"or none (found {','.join(present)})"
    )


def _times(table: CsvTable, segment: np.ndarray, last: _Last | None) -> np.ndarray:
    """Column ``t``, s; finite and strictly increasing within each segment (from ``last`` on)."""
    t = _finite_floats(table, "t")
    before = 0 if last is None else 1
    t_all = t if last is None else np.r_[last.t, t]
    segment_all = segment if last is None else np.r_[last.segment, segment]
    runs = change_runs(segment_all)
    bad = np.flatnonzero((runs[1:] == runs[:-1]) & ~(t_all[1:] > t_all[:-1]))
    if bad.size:
        k = int(bad[0])
        row = k - before  # in this chunk; -1 is the previous chunk's last row
        line = table.lines[row] if row >= 0 or last is None else last.line
        raise table.error(
            f"time {float(t_all[k + 1])!r} s is not after {float(t_all[k])!r} s on line "
            f"{line}; time must strictly increase within a segment "
            f"(segment {int(segment_all[k])})",
            row=row + 1,
            column="t",
        )
    gaps = np.flatnonzero((runs[1:] == runs[:-1]) & (t_all[1:] - t_all[:-1] > MAX_SEGMENT_GAP))
    if gaps.size:
        k = int(gaps[0])
        raise table.error(
            f"{float(t_all[k + 1] - t_all[k]):.6g} s without wheel speeds within segment "
            f"{int(segment_all[k])} (t = {float(t_all[k])!r} -> {float(t_all[k + 1])!r} s), more "
            f"than {MAX_SEGMENT_GAP:g} s: a recording break or a wrong stamp? Start a new "
            "segment there (column 'segment') or remove the row",
            row=k + 1 - before,
            column="t",
        )
    return t


def _finite_floats(table: CsvTable, column: str) -> np.ndarray:
    """Column ``column`` as float64; every cell must be a finite number."""
    values = table.convert(column, float, np.float64, _not_a_number)
    _raise_on_first(table, column, ~np.isfinite(values), "{cell} is not a finite number")
    return values


def _optional_floats(table: CsvTable, column: str) -> np.ndarray:
    """Column ``column`` as float64 with NaN for empty (or ``nan``) cells; no infinities."""
    try:  # fast path: no Python-level call per cell, but no whitespace-only cells either
        values = floats_or_nan(table.cells(column))
    except ValueError:
        values = table.convert(column, _float_or_nan, np.float64, _not_a_number)
    _raise_on_first(table, column, np.isinf(values), "{cell} is not a finite number")
    return values


def _pose(table: CsvTable, columns: Sequence[str]) -> np.ndarray:
    """Pose ``x, y, yaw`` of shape (N, 3), NaN where not measured; yaw wrapped."""
    pose = np.full((len(table), 3), np.nan)
    for column in columns:
        pose[:, _POSE_COLUMNS.index(column)] = _optional_floats(table, column)
    has_x, has_y = ~np.isnan(pose[:, 0]), ~np.isnan(pose[:, 1])
    _raise_on_first(table, "y", has_x & ~has_y, "missing while x is given; give both or neither")
    _raise_on_first(table, "x", has_y & ~has_x, "missing while y is given; give both or neither")
    pose[:, 2] = wrap_angle(pose[:, 2])
    return pose


def _terrain(table: CsvTable) -> np.ndarray | None:
    """Column ``terrain`` as a str array, or None if absent; labels must be non-empty."""
    if "terrain" not in table.header:
        return None
    cells = table.cells("terrain")
    stripped = {label: label.strip() for label in set(cells)}  # few distinct labels
    labels = np.array(list(map(stripped.__getitem__, cells)), dtype=str)
    _raise_on_first(table, "terrain", labels == "", "empty label; every row needs a terrain")
    return labels


def _segments(table: CsvTable, last: _Last | None, seen: set[int]) -> np.ndarray:
    """Column ``segment`` as int64 (zeros if absent); each id forms one contiguous run.

    ``seen`` holds the ids of the earlier chunks (updated), ``last`` their last row.
    """
    if "segment" not in table.header:
        segment = np.zeros(len(table), dtype=np.int64)
    else:
        segment = table.convert("segment", int, np.int64, _not_an_integer)
    starts = run_starts(segment)
    if last is not None and segment[0] == last.segment:
        starts = starts[1:]  # the previous chunk's segment goes on
    for start, value in zip(starts.tolist(), segment[starts].tolist(), strict=True):
        if value in seen:
            raise table.error(
                f"segment {value} starts again after other segments; "
                "rows of a segment must be consecutive",
                row=start,
                column="segment",
            )
        seen.add(value)
    return segment


def _raise_on_first(table: CsvTable, column: str, bad: np.ndarray, problem: str) -> None:
    """Raise about the first row where ``bad`` is True.

    ``problem`` is the message; ``{cell}`` in it is replaced by the quoted cell.
    """
    rows = np.flatnonzero(bad)
    if rows.size:
        row = int(rows[0])
        cell = table.rows[row][table.header.index(column)].strip()
        raise table.error(problem.format(cell=shown(cell)), row=row, column=column)


def _float_or_nan(cell: str) -> float:
    """Parse a float; an empty (whitespace-only) cell is NaN."""
    return float(cell) if cell.strip() else math.nan


def _not_a_number(cell: str) -> str:
    """Message for a cell that is not a number."""
    text = cell.strip()
    return f"{shown(text)} is not a number" if text else "empty cell, expected a number"


def _not_an_integer(cell: str) -> str:
    """Message for a cell that is not an integer."""
    text = cell.strip()
    return f"{shown(text)} is not an integer" if text else "empty cell, expected an integer"
