"""Ground-truth files: the true pose, ICRs and terrain of a run over time.

``groundtruth.csv`` (written by ``terrain-odom simulate``) has the columns
``t,x,y,yaw,y_l,y_r,x_icr,terrain`` (s, m, m, rad, m, m, m, label), optionally
``alpha`` (slip factor); other columns are ignored. Times must increase
strictly; every cell must be a finite number (a label for ``terrain``).

Examples
--------
>>> import io
>>> gt = read_groundtruth(io.StringIO(
...     "t,x,y,yaw,y_l,y_r,x_icr,terrain\\n0,0,0,0,0.4,-0.4,0,grass\\n0.1,0.05,0,0,0.4,-0.4,0,grass\\n"))
>>> gt.pose.shape, gt.terrain.tolist()
((2, 3), ['grass', 'grass'])
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from terrain_odom.io._csv import Source, read_csv, shown

__all__ = ["GroundTruth", "read_groundtruth", "GROUNDTRUTH_COLUMNS"]

GROUNDTRUTH_COLUMNS = ("t", "x", "y", "yaw", "y_l", "y_r", "x_icr", "terrain")
"""Required columns of a ground-truth file."""


@dataclass(frozen=True)
class GroundTruth:
    """True state of a run.

    Attributes
    ----------
    t : ndarray, shape (N,)
        Times, s, strictly increasing.
    pose : ndarray, shape (N, 3)
        ``x, y, yaw`` (m, m, rad).
    icr : ndarray, shape (N, 3)
        ``y_l, y_r, x_icr``, m.
    alpha : ndarray, shape (N,), or None
        Longitudinal slip factor, if the file has it.
    terrain : ndarray of str, shape (N,)
        Terrain under the robot.
    source : str
        File name, for messages.
    """

    t: np.ndarray
    pose: np.ndarray
    icr: np.ndarray
    alpha: np.ndarray | None
    terrain: np.ndarray
    source: str

    def __len__(self) -> int:
        return int(self.t.size)

    def covers(self, t: np.ndarray) -> bool:
        """Whether the ground truth spans the times ``t`` (s; 1 ns slack)."""
        return bool(t.size == 0 or (t[0] >= self.t[0] - 1e-9 and t[-1] <= self.t[-1] + 1e-9))

    def changes(self) -> list[tuple[float, str, str]]:
        """Return the true terrain changes ``(t, previous, new)`` (t: first row on the new one)."""
        rows = np.flatnonzero(self.terrain[1:] != self.terrain[:-1]) + 1
        return [(float(self.t[k]), str(self.terrain[k - 1]), str(self.terrain[k])) for k in rows]


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
