"""Terrain change confirmation (Chen et al. 2023, Sec. 3.2.3).

A change of terrain is confirmed only when the new label has been observed
on ``confirm`` consecutive observations (frames, or log rows when the labels
come from the log), which filters out single misclassifications. Each
observation may carry a mark (e.g. where the classified ground is along the
path); a confirmed change reports the mark of its *first* observation, so
the change can be applied where the new terrain was first seen.
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
    >>> [tr.observe(s, at=d) for s, d in [("mud", 7.0), ("mud", 8.0)]]
    [None, 'mud']
    >>> tr.changed_at
    7.0
    """

    def __init__(self, confirm: int = 2) -> None:
        if confirm < 1:
            raise ValueError(f"confirm must be >= 1, got {confirm}")
        self.confirm = confirm
        self.current: str | None = None
        self._candidate: str | None = None
        self._count = 0
        self._candidate_at: float | None = None
        self.changed_at: float | None = None

    def steady(self, label: str) -> bool:
        """Whether observing ``label`` now would change nothing (it is the current terrain)."""
        return label == self.current and self._candidate is None

    def observe(self, label: str, at: float | None = None) -> str | None:
        """Feed one observation; return the new label when a change is confirmed.

        The first observation sets the current terrain without reporting a
        change. ``at`` is an optional mark of the observation; after a
        confirmed change, :attr:`changed_at` holds the mark of the first of
        the consecutive observations that confirmed it.
        """
        if self.current is None:
            self.current = label
            return None
        if label == self.current:
            self._candidate, self._count = None, 0
            return None
        if label != self._candidate:
            self._candidate, self._count, self._candidate_at = label, 0, at
        self._count += 1
        if self._count < self.confirm:
            return None
        self.current, self._candidate, self._count = label, None, 0
        self.changed_at = self._candidate_at
        return label
