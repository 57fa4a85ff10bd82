"""Ground-truth files: the true pose, ICRs and terrain of a run over time.

``groundtruth.csv`` (written by ``terrain-odom simulate``) has the columns
``t,x,y,yaw,y_l,y_r,x_icr,terrain`` (s, m, m, rad, m, m, m, label), optionally
``alpha`` (slip factor); other columns are ignored. Times must increase
strictly; every cell must be a finite number (a label for ``terrain``).

Examples
--------
>>> import io
>>> truth = read_groundtruth(io.StringIO(
...     "t,x,y,yaw,y_l,y_r,x_icr,terrain\\n0,0,0,0,0.4,-0.4,0,grass\\n0.1,0.05,0,0,0.4,-0.4,0,grass\\n"))
>>> truth.pose.shape, truth.terrain.tolist()
((2, 3), ['grass', 'grass'])
"""

from __future__ import annotations

import math

import numpy as np

from terrain_odom.io._csv import Source, read_csv, shown
from terrain_odom.records import GroundTruth

__all__ = ["read_groundtruth", "GROUNDTRUTH_COLUMNS"]

GROUNDTRUTH_COLUMNS = ("t", "x", "y", "yaw", "y_l", "y_r", "x_icr", "terrain")
"""Required columns of a ground-truth file."""


def _finite(cell: str) -> float:
    value = float(cell)
    if not math.isfinite(value):
        raise ValueError(cell)
    return value


def read_groundtruth(source: Source) -> GroundTruth:
    """Read and validate a ground-truth CSV file.

    Raises
    ------
    InputFileError
        A required column is missing, a cell is not a finite number, a
        terrain label is empty, or the times do not increase strictly (the
        message names the file, line and column).
    """
    table = read_csv(source)
    table.require_columns(*GROUNDTRUTH_COLUMNS, reason="true pose, ICRs and terrain")
    numeric = [c for c in GROUNDTRUTH_COLUMNS if c != "terrain"]
    if "alpha" in table.header:
        numeric.append("alpha")
    values = {
        c: table.convert(
            c, _finite, np.float64, lambda cell: f"{shown(cell)} is not a finite number"
        )
        for c in numeric
    }
    terrain = np.array([cell.strip() for cell in table.cells("terrain")], dtype=str)
    empty = np.flatnonzero(terrain == "")
    if empty.size:
        raise table.error("empty terrain label", row=int(empty[0]), column="terrain")
    t = values["t"]
    if t.size < 2:
        raise table.error("needs at least two rows of ground truth")
    bad = np.flatnonzero(np.diff(t) <= 0.0)
    if bad.size:
        raise table.error(
            f"time {t[bad[0] + 1]!r} s does not increase (previous row {t[bad[0]]!r} s)",
            row=int(bad[0] + 1),
            column="t",
        )
    return GroundTruth(
        t=t,
        pose=np.column_stack([values["x"], values["y"], values["yaw"]]),
        icr=np.column_stack([values["y_l"], values["y_r"], values["x_icr"]]),
        alpha=values.get("alpha"),
        terrain=terrain,
        source=table.name,
    )
