"""Terrain change confirmation (Chen et al. 2023, Sec. 3.2.3) and its flow into the filter.

A change of terrain is confirmed only when the new label has been observed
on ``confirm`` consecutive observations (frames, or log rows when the labels
come from the log), which filters out single misclassifications. Each
observation may carry a mark (e.g. where the classified ground is along the
path); a confirmed change reports the mark of its *first* observation, so
the change can be applied where the new terrain was first seen.

The arrival rule places that ground: an odometer integrates the speed of the
current kinematic model (:func:`model_speed`, the track speeds held from one
wheel sample to the next, nothing across a segment break), and ground seen
``ahead`` m in front is reached once the odometer has gone ``ahead`` m
further. :class:`TerrainFlow` applies it sample by sample in the stream
(:class:`~terrain_odom.estimation.online.OnlineOdometry`); :class:`Odometer`
over a whole log, for the time a frame's ground is reached.
"""

from __future__ import annotations

from collections import deque
from dataclasses import replace
from typing import TYPE_CHECKING, Protocol

import numpy as np

from terrain_odom.kinematics import twist_icr
from terrain_odom.records import Sighting, TerrainChange

if TYPE_CHECKING:
    from terrain_odom.config import Config
    from terrain_odom.records import WheelLog

__all__ = ["Odometer", "RowFilter", "TerrainFlow", "TerrainTracker", "model_speed"]


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
            self._candidate = None  # the count restarts with the next candidate
            return None
        if label != self._candidate:
            self._candidate, self._count, self._candidate_at = label, 0, at
        self._count += 1
        if self._count < self.confirm:
            return None
        self.current, self._candidate = label, None
        self.changed_at = self._candidate_at
        return label


class RowFilter(Protocol):
    """The part of a filter the terrain flow uses."""

    t: float
    terrain: str | None

    def set_terrain(self, label: str) -> None:
        """Name the terrain the filter starts on, without any reset."""
        ...  # pragma: no cover

    def reset_on_terrain_change(self, label: str) -> TerrainChange:
        """Apply a confirmed change to terrain ``label``."""
        ...  # pragma: no cover


class TerrainFlow:
    """Terrain labels into filter resets: confirmation, scheduling, odometer.

    ``seen`` is the terrain confirmed by the observations (ahead of the
    robot for a camera); ``ekf.terrain`` the one applied to the filter.
    """

    def __init__(self, ekf: RowFilter, config: Config) -> None:
        self.ekf = ekf
        self.adapt = config.terrain.adapt
        self.on_arrival = config.terrain.reset_at == "arrival"
        self.tracker = TerrainTracker(config.terrain.confirm)
        self.travelled = 0.0  # m, odometer of the model's predicted motion
        # The odometer only places ground seen ahead: it runs from the first sighting
        # with ahead > 0 (arrival mode). Before, every target is the odometer's value at
        # the sighting, reached at once whether it counted or not.
        self.odometer_on = False
        self.pending: deque[tuple[float, str, float]] = deque()  # (odometer target, label, t)
        self.changes: list[TerrainChange] = []

    @property
    def seen(self) -> str | None:
        """Terrain confirmed by the observations so far."""
        return self.tracker.current

    def steady(self, label: Sighting | None) -> bool:
        """Whether observing ``label`` (None: no label) at every row would change nothing.

        Nothing but the odometer, which :meth:`travel_rows` advances over rows run in one call.
        """
        if self.pending:
            return False
        return label is None or (self.ekf.terrain is not None and self.tracker.steady(label.label))

    def travel(self, distance: float) -> None:
        """Advance the odometer by ``distance`` m."""
        self.travelled += distance

    def travel_rows(
        self, dt: np.ndarray, speeds: tuple[np.ndarray, np.ndarray], params: np.ndarray
    ) -> None:
        """Advance the odometer over steps predicted in one call, as :meth:`travel` step by step.

        Parameters
        ----------
        dt : ndarray, shape (B,)
            Length of each step, s.
        speeds : tuple of ndarray, each of shape (B,)
            Track speeds ``v_l, v_r`` held over each step, m/s.
        params : ndarray, shape (B, 3) to (B, 4)
            ``y_l, y_r, x_icr(, alpha)`` of the model at the start of each step.
        """
        if not self.odometer_on:
            return
        steps = np.asarray(model_speed(*speeds, params.T)) * dt  # m, the same floats per step
        self.travelled = float(np.concatenate(([self.travelled], steps)).cumsum()[-1])  # in order

    def apply_reached(self) -> None:
        """Apply the pending changes whose ground the robot has reached."""
        while self.pending and self.travelled >= self.pending[0][0]:
            _, label, t_confirmed = self.pending.popleft()
            self._apply(label, t_confirmed)

    def observe(self, sighting: Sighting) -> None:
        """Feed one label; name the first terrain, apply or schedule a confirmed change."""
        where = self.travelled + (sighting.ahead if self.on_arrival else 0.0)
        self.odometer_on = self.odometer_on or where > self.travelled
        confirmed = self.tracker.observe(sighting.label, at=where)
        if self.ekf.terrain is None:
            self.ekf.set_terrain(self.tracker.current or sighting.label)
            return
        if confirmed is None:
            return
        target = self.tracker.changed_at
        if target is not None and target > self.travelled:
            self.pending.append((target, confirmed, self.ekf.t))
        elif not self.pending:
            self._apply(confirmed, None)
        else:  # reached already, but earlier changes are still pending: keep the order
            self.pending.append((self.travelled, confirmed, self.ekf.t))

    def _apply(self, label: str, t_confirmed: float | None) -> None:
        ekf = self.ekf
        if label == ekf.terrain:
            return
        if self.adapt:
            change = ekf.reset_on_terrain_change(label)
        else:
            change = TerrainChange(ekf.t, ekf.terrain, label, restored=False, reset=False)
            ekf.set_terrain(label)
        if t_confirmed is not None and t_confirmed < change.t:
            change = replace(change, t_confirmed=t_confirmed)
        self.changes.append(change)


def model_speed(
    v_l: float | np.ndarray, v_r: float | np.ndarray, params: np.ndarray
) -> np.ndarray | float:
    """Return the speed of the kinematic model's motion, m/s: what the odometer integrates.

    Parameters
    ----------
    v_l, v_r : float or ndarray
        Track surface speeds, m/s.
    params : ndarray, shape (3,) to (4,), or (3, N) to (4, N)
        ``y_l, y_r, x_icr`` (m) and ``alpha`` (1 if left out) of the model
        at those speeds.

    Returns
    -------
    float or ndarray
        One speed per pair of track speeds, m/s.
    """
    v_x, v_y, _ = twist_icr(v_l, v_r, *params)
    return np.hypot(v_x, v_y)


class Odometer:
    """The arrival rule over a whole log: distance the model travels, m.

    Parameters
    ----------
    log : WheelLog
        Times and track speeds; nothing is integrated across its segment breaks.
    states : ndarray, shape (N, 6) or (N, 7)
        The ICR EKF's estimate after each row: ``y_l, y_r, x_icr(, alpha)``
        from column 3 on.
    """

    def __init__(self, log: WheelLog, states: np.ndarray) -> None:
        self.t = log.t
        self.speed = np.asarray(model_speed(log.v_l, log.v_r, states[:, 3:].T))  # m/s, held
        step = self.speed[:-1] * np.diff(log.t)
        step[log.run_starts()[1:] - 1] = 0.0
        self.s = np.r_[0.0, np.cumsum(step)]
        self.run = log.segment_runs()

    def arrival(self, row: int, t: float, distance: float) -> float | None:
        """Time the robot, at ``t`` after ``row``, has gone ``distance`` m further; None if never.

        None when its segment ends first.
        """
        s_t = self.s[row] + self.speed[row] * (t - self.t[row])
        target = s_t + distance
        if target <= s_t:
            return t
        j = int(np.searchsorted(self.s, target, side="left"))
        if j >= self.s.size or self.run[j] != self.run[row]:
            return None
        return float(self.t[j - 1] + (target - self.s[j - 1]) / self.speed[j - 1])
