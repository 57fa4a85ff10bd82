"""Typed records shared by the modules of terrain-odom.

All arrays follow the package convention: x forward, y left, yaw
counter-clockwise in radians wrapped to (-pi, pi], SI units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["WheelLog"]


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
