"""Terrain change confirmation (Chen et al. 2023, Sec. 3.2.3).

A change of terrain is confirmed only when the new label has been observed
on ``confirm`` consecutive observations (frames, or log rows when the labels
come from the log), which filters out single misclassifications.
"""

from __future__ import annotations

__all__ = ["TerrainTracker"]


class TerrainTracker:
    """Confirm terrain changes after ``confirm`` consecutive observations.

    Parameters
    ----------
    confirm : int
        Consecutive observations of a new label needed (>= 1).

    Examples
    --------
    >>> tr = TerrainTracker(confirm=2)
    >>> [tr.observe(s) for s in ["grass", "sand", "grass", "sand", "sand"]]
    [None, None, None, None, 'sand']
    >>> tr.current
    'sand'
    """

    def __init__(self, confirm: int = 2) -> None:
        if confirm < 1:
            raise ValueError(f"confirm must be >= 1, got {confirm}")
        self.confirm = confirm
        self.current: str | None = None
        self._candidate: str | None = None
        self._count = 0

    def observe(self, label: str) -> str | None:
        """Feed one observation; return the new label when a change is confirmed.

        The first observation sets the current terrain without reporting a
        change.
        """
        if self.current is None:
            self.current = label
            return None
        if label == self.current:
            self._candidate, self._count = None, 0
            return None
        if label != self._candidate:
            self._candidate, self._count = label, 0
        self._count += 1
        if self._count < self.confirm:
            return None
        self.current, self._candidate, self._count = label, None, 0
        return label
