"""Typed records shared by every layer of terrain-odom (pure data, no behaviour beyond masks).

All arrays follow the package convention: x forward, y left, yaw
counter-clockwise in radians wrapped to (-pi, pi], SI units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["WheelLog", "Sighting", "TerrainChange", "GroundTruth", "change_runs", "run_starts"]


def change_runs(*keys: ArrayLike) -> np.ndarray:
    """Run id per row, shape (N,): 0 on the first row, +1 wherever any key changes.

    Parameters
    ----------
    *keys : array_like, shape (N,)
        Per-row keys (e.g. ``segment`` ids, terrain labels); at least one.

    Examples
    --------
    >>> change_runs([0, 0, 1, 1, 1], ["a", "b", "b", "b", "b"]).tolist()
    [0, 1, 2, 2, 2]
    """
    arrays = [np.asarray(key) for key in keys]
    if arrays[0].size == 0:
        return np.zeros(0, dtype=int)
    changed = np.logical_or.reduce([a[1:] != a[:-1] for a in arrays])
    return np.concatenate([[0], np.cumsum(changed)]).astype(int)


def run_starts(*keys: ArrayLike) -> np.ndarray:
    """First row of every run of :func:`change_runs`, shape (R,); empty for no rows.

    Examples
    --------
    >>> run_starts([3, 3, 5, 3]).tolist()
    [0, 2, 3]
    """
    runs = change_runs(*keys)
    return np.flatnonzero(np.r_[True, runs[1:] != runs[:-1]]) if runs.size else runs


@dataclass(frozen=True)
class WheelLog:
    """A wheel log: track surface speeds with optional pose measurements.

    Row ``k`` holds the speeds commanded/measured at ``t[k]``; they are held
    constant until ``t[k+1]`` (zero-order hold) when integrating.

    Attributes
    ----------
    t : ndarray, shape (N,)
        Time, s; strictly increasing within each segment.
    v_l, v_r : ndarray, shape (N,)
        Left and right track (wheel) surface speeds, m/s, forward positive.
    pose : ndarray, shape (N, 3)
        Measured pose ``x, y, yaw`` (m, m, rad) or NaN on rows without a
        measurement. ``yaw`` may be present while ``x, y`` are NaN
        (heading-only measurement).
    terrain : ndarray of str, shape (N,), or None
        True terrain label per row, if the log has one.
    segment : ndarray of int, shape (N,)
        Segment id per row; integration and comparison never cross a change.
    source : str
        Where the log came from (file name), for messages and reports.
    """

    t: np.ndarray
    v_l: np.ndarray
    v_r: np.ndarray
    pose: np.ndarray
    terrain: np.ndarray | None
    segment: np.ndarray
    source: str = "<memory>"

    def __len__(self) -> int:
        return int(self.t.shape[0])

    def segment_runs(self) -> np.ndarray:
        """Run id per row, shape (N,): 0 on the first row, +1 at every change of ``segment``.

        The one definition of where a log breaks: integration, windows,
        fits and the row loop never cross from one run to the next (a
        ``segment`` id that comes back later starts a new run). See
        :func:`change_runs`.

        Examples
        --------
        >>> import numpy as np
        >>> log = WheelLog(np.arange(5.0), np.ones(5), np.ones(5), np.full((5, 3), np.nan),
        ...                None, np.array([0, 0, 1, 1, 0]))
        >>> log.segment_runs().tolist(), log.n_runs, log.run_starts().tolist()
        ([0, 0, 1, 1, 2], 3, [0, 2, 4])
        >>> log.run_ranges()
        [range(0, 2), range(2, 4), range(4, 5)]
        """
        return change_runs(self.segment)

    def run_starts(self) -> np.ndarray:
        """First row of every run (see :meth:`segment_runs`), shape (R,)."""
        return run_starts(self.segment)

    def run_ranges(self) -> list[range]:
        """Rows of every run (see :meth:`segment_runs`), in order."""
        starts = self.run_starts().tolist()
        ends = [*starts[1:], len(self)] if starts else []
        return [range(a, b) for a, b in zip(starts, ends, strict=True)]

    def take(self, rows: np.ndarray | slice, source: str | None = None) -> WheelLog:
        """Return the log of ``rows`` (indices, a mask or a slice), segments kept.

        ``source`` names it (default: this log's).
        """
        return WheelLog(
            self.t[rows],
            self.v_l[rows],
            self.v_r[rows],
            self.pose[rows],
            None if self.terrain is None else self.terrain[rows],
            self.segment[rows],
            self.source if source is None else source,
        )

    @property
    def n_runs(self) -> int:
        """Number of runs (see :meth:`segment_runs`); 0 for an empty log."""
        return int(self.run_starts().size)

    @property
    def has_position(self) -> np.ndarray:
        """Boolean mask, shape (N,): rows with a measured ``x, y``."""
        return np.isfinite(self.pose[:, 0]) & np.isfinite(self.pose[:, 1])

    @property
    def has_yaw(self) -> np.ndarray:
        """Boolean mask, shape (N,): rows with a measured ``yaw``."""
        return np.isfinite(self.pose[:, 2])

    @property
    def has_pose(self) -> np.ndarray:
        """Boolean mask, shape (N,): rows with a full ``x, y, yaw`` measurement."""
        return self.has_position & self.has_yaw


@dataclass(frozen=True)
class Sighting:
    """A terrain label seen by the camera.

    Attributes
    ----------
    label : str
        Terrain class of the classified region.
    ahead : float
        Distance along the path from the robot to that region, m (0: under
        the robot).
    """

    label: str
    ahead: float = 0.0


@dataclass(frozen=True)
class TerrainChange:
    """A confirmed terrain change applied to the filter.

    Attributes
    ----------
    t : float
        Filter time of the reset, s.
    previous, label : str or None
        Terrain before and after.
    restored : bool
        Whether a remembered ICR estimate of ``label`` was restored.
    reset : bool
        Whether the ICR covariance was reset to ``P_B`` (False when terrain
        adaptation is off and the change is only recorded).
    t_confirmed : float or None
        When the change was confirmed, s, if earlier than ``t`` (a reset
        scheduled for the robot's arrival on ground seen ahead).
    prior : bool
        Whether the ICR estimate was set to the offline prior of ``label``
        (:class:`~terrain_odom.estimation.icr_ekf.IcrPriors`) instead of keeping it with ``P_B``.
    """

    t: float
    previous: str | None
    label: str
    restored: bool
    reset: bool = True
    t_confirmed: float | None = None
    prior: bool = False


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
