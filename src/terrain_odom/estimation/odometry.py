"""Run the ICR EKF over a wheel log, row by row.

Row ``k`` of a log holds the wheel speeds at ``t[k]``, held until
``t[k+1]``; the filter predicts over ``[t[k-1], t[k]]`` with the speeds of
row ``k-1``, then fuses the pose measurement of row ``k`` if there is one. The
pose is anchored at the first pose measurement of every log segment and is
never propagated across a segment break. Terrain labels (from the log or a
classifier) pass through a :class:`TerrainTracker`; a confirmed change resets
the ICR covariance to ``P_B`` (and restores a remembered estimate).

A camera sees ground ahead of the robot. With ``terrain.reset_at:
arrival`` a change confirmed from frames is applied once the robot has
travelled (speed of the current kinematic model, integrated) to where the first
frame of the new terrain looked; pending changes are applied in order.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np

from terrain_odom.config import Config
from terrain_odom.estimation.icr_ekf import IcrEkf, IcrPriors
from terrain_odom.estimation.terrain import TerrainTracker
from terrain_odom.kinematics import twist_icr
from terrain_odom.records import Sighting, TerrainChange, WheelLog

__all__ = [
    "FrameObserver",
    "OdometryRow",
    "OdometryResult",
    "RowFilter",
    "RowStepper",
    "run_icr_ekf",
    "run_rows",
]


@dataclass(frozen=True)
class OdometryRow:
    """The filter's estimate after processing one log row.

    Attributes
    ----------
    index : int
        Row of the log.
    t : float
        Time, s.
    state : ndarray, shape (n,)
        ``x, y, yaw, y_l, y_r, x_icr(, alpha)``.
    std : ndarray, shape (n,)
        Standard deviation of each state.
    terrain : str
        Confirmed terrain label, ``""`` if none.
    """

    index: int
    t: float
    state: np.ndarray
    std: np.ndarray
    terrain: str


class FrameObserver(Protocol):
    """Camera frames interleaved with the log rows (see :func:`run_icr_ekf`).

    ``times`` are the frame times (s, non-decreasing). For each frame in the
    log's time span, :meth:`observe` returns the :class:`Sighting` (None if
    none, e.g. an unreadable frame) from the current wheel speeds and ICR
    parameters, then :meth:`confirmed` gets the terrain confirmed by the
    camera after the tracker has seen that label.
    """

    times: np.ndarray

    def observe(
        self, index: int, t: float, v_l: float, v_r: float, icr_params: np.ndarray
    ) -> Sighting | None:
        """Return what frame ``index`` shows (None: no label)."""
        ...  # pragma: no cover

    def confirmed(self, index: int, label: str) -> None:
        """Take the camera-confirmed terrain after frame ``index`` (``""`` if none yet)."""
        ...  # pragma: no cover


@dataclass
class OdometryResult:
    """Everything an EKF run over a log produced.

    Attributes
    ----------
    names : tuple of str
        State names, in column order of ``states``.
    states, stds : ndarray, shape (N, n)
        Estimate and standard deviation after each row.
    terrain : ndarray of str, shape (N,)
        Confirmed terrain per row (``""`` before any label).
    changes : list of TerrainChange
        Confirmed terrain changes, with the log time of each.
    n_updates : int
        Pose measurements fused.
    frames_before, frames_after : int
        Frames before the first log row or after the last one (skipped).
    """

    names: tuple[str, ...]
    states: np.ndarray
    stds: np.ndarray
    terrain: np.ndarray
    changes: list[TerrainChange] = field(default_factory=list)
    n_updates: int = 0
    frames_before: int = 0
    frames_after: int = 0


class RowFilter(Protocol):
    """The part of a filter the shared row loop uses for terrain adaptation."""

    t: float
    terrain: str | None

    def set_terrain(self, label: str) -> None:
        """Name the terrain the filter starts on, without any reset."""
        ...  # pragma: no cover

    def reset_on_terrain_change(self, label: str) -> TerrainChange:
        """Apply a confirmed change to terrain ``label``."""
        ...  # pragma: no cover


class RowStepper(Protocol):
    """One estimator driven by :func:`run_rows` over the rows of a log.

    For every row ``k`` the loop calls :meth:`advance` (propagate to
    ``t[k]``; ``new_segment`` when row ``k`` starts a new log segment), then
    feeds the row's terrain label, then calls :meth:`measure` (fuse the row's
    measurement; True if one was fused), then observes camera frames with
    :meth:`icr_params` and records :meth:`row`.
    """

    filter: RowFilter
    names: tuple[str, ...]

    def advance(self, k: int, new_segment: bool) -> None:
        """Propagate from row ``k - 1`` to row ``k``."""
        ...  # pragma: no cover

    def measure(self, k: int) -> bool:
        """Fuse the measurement of row ``k``; True if an update was made."""
        ...  # pragma: no cover

    def icr_params(self, k: int) -> np.ndarray:
        """Return the current ``y_l, y_r, x_icr(, alpha)`` at row ``k`` (camera ROI)."""
        ...  # pragma: no cover

    def row(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Estimate and standard deviation after row ``k``, in ``names`` order."""
        ...  # pragma: no cover


class _IcrSteps:
    """:class:`RowStepper` of the ICR EKF: predict every row, update at pose rows."""

    def __init__(self, ekf: IcrEkf, log: WheelLog) -> None:
        self.filter = ekf
        self.names = ekf.names
        self._log = log
        self._anchored = False

    def advance(self, k: int, new_segment: bool) -> None:
        log = self._log
        if new_segment:
            self._anchored = False  # a break: nothing is integrated across it
            self.filter.t = float(log.t[k])
        elif k > 0:
            self.filter.predict(log.v_l[k - 1], log.v_r[k - 1], float(log.t[k] - log.t[k - 1]))

    def measure(self, k: int) -> bool:
        z = self._log.pose[k]
        if np.all(np.isfinite(z)) and not self._anchored:
            self.filter.reset_pose(z)
            self._anchored = True
        elif np.any(np.isfinite(z)) and self._anchored:
            self.filter.update(z)
            return True
        return False

    def icr_params(self, k: int) -> np.ndarray:
        return self.filter.params

    def row(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        return self.filter.x, self.filter.std


def run_icr_ekf(
    log: WheelLog,
    config: Config,
    *,
    labels: Sequence[str] | None = None,
    on_row: Callable[[OdometryRow], None] | None = None,
    frames: FrameObserver | None = None,
    priors: IcrPriors | None = None,
) -> OdometryResult:
    """Estimate pose and ICRs over a whole log.

    Parameters
    ----------
    log : WheelLog
        Wheel speeds and pose measurements.
    config : Config
        Filter and terrain settings; ``config.terrain.adapt`` switches the
        covariance reset on terrain changes.
    labels : sequence of str, shape (N,), optional
        Terrain label observed at each row (e.g. ``log.terrain``); ``None``
        runs without terrain information.
    on_row : callable, optional
        Called with an :class:`OdometryRow` after every row (to stream output).
    frames : FrameObserver, optional
        Camera frames supplying the terrain labels (instead of ``labels``):
        a frame at ``t_f`` is observed right after the last row with
        ``t <= t_f`` (with that row's wheel speeds and the filter's state
        then); frames before the first row or after the last are skipped.
    priors : IcrPriors, optional
        Offline ICR parameters seeding the filter at the start and on
        confirmed changes (see :class:`~terrain_odom.estimation.icr_ekf.IcrEkf`).

    Returns
    -------
    OdometryResult
    """
    ekf = IcrEkf(config.ekf, config.terrain, priors=priors)
    return run_rows(log, config, _IcrSteps(ekf, log), labels=labels, on_row=on_row, frames=frames)


def run_rows(
    log: WheelLog,
    config: Config,
    stepper: RowStepper,
    *,
    labels: Sequence[str] | None = None,
    on_row: Callable[[OdometryRow], None] | None = None,
    frames: FrameObserver | None = None,
) -> OdometryResult:
    """Drive an estimator over every row of a log (see :class:`RowStepper`).

    Segment breaks, terrain tracking (labels or camera frames, the ``P``
    reset on a confirmed change) and the per-row output are shared by every
    estimator; the arguments are those of :func:`run_icr_ekf`.
    """
    if labels is not None and len(labels) != len(log):
        raise ValueError(f"labels has {len(labels)} entries for a log of {len(log)} rows")
    if labels is not None and frames is not None:
        raise ValueError("give terrain labels or frames, not both")
    ekf = stepper.filter
    ekf.t = float(log.t[0]) if len(log) else 0.0
    flow = _TerrainFlow(ekf, config)
    n_rows, n_state = len(log), len(stepper.names)
    states = np.empty((n_rows, n_state))
    stds = np.empty((n_rows, n_state))
    terrain = np.full(n_rows, "", dtype=object)
    n_updates = 0
    frame_t = np.empty(0) if frames is None else np.asarray(frames.times, dtype=float)
    # frames observed after row k: those with t[k] <= t_f < t[k + 1] (t_f <= t[-1] for the last)
    bounds = np.searchsorted(frame_t, log.t, side="left") if n_rows else np.zeros(0, int)
    n_after = int(frame_t.size - np.searchsorted(frame_t, log.t[-1], side="right")) if n_rows else 0
    frames_before = int(bounds[0]) if n_rows else int(frame_t.size)
    for k in range(n_rows):
        new_segment = k > 0 and log.segment[k] != log.segment[k - 1]
        if k > 0 and not new_segment:  # odometer over the step about to be predicted
            v_x, v_y, _ = twist_icr(log.v_l[k - 1], log.v_r[k - 1], *stepper.icr_params(k - 1))
            flow.travel(float(np.hypot(v_x, v_y)) * float(log.t[k] - log.t[k - 1]))
        stepper.advance(k, new_segment)
        flow.apply_reached()
        if labels is not None:
            flow.observe(Sighting(str(labels[k])))
        n_updates += stepper.measure(k)
        if frames is not None:
            stop = int(bounds[k + 1]) if k + 1 < n_rows else frame_t.size - n_after
            for i in range(int(bounds[k]), stop):
                sighting = frames.observe(
                    i,
                    float(frame_t[i]),
                    float(log.v_l[k]),
                    float(log.v_r[k]),
                    stepper.icr_params(k),
                )
                if sighting is not None:
                    flow.observe(sighting)
                frames.confirmed(i, flow.seen or "")
        states[k], stds[k] = stepper.row(k)
        terrain[k] = ekf.terrain or ""
        if on_row is not None:
            on_row(OdometryRow(k, float(log.t[k]), states[k], stds[k], terrain[k]))
    return OdometryResult(
        stepper.names,
        states,
        stds,
        terrain.astype(str),
        flow.changes,
        n_updates,
        frames_before=frames_before,
        frames_after=n_after,
    )


class _TerrainFlow:
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
        self.pending: deque[tuple[float, str, float]] = deque()  # (odometer target, label, t)
        self.changes: list[TerrainChange] = []

    @property
    def seen(self) -> str | None:
        """Terrain confirmed by the observations so far."""
        return self.tracker.current

    def travel(self, distance: float) -> None:
        """Advance the odometer by ``distance`` m."""
        self.travelled += distance

    def apply_reached(self) -> None:
        """Apply the pending changes whose ground the robot has reached."""
        while self.pending and self.travelled >= self.pending[0][0]:
            _, label, t_confirmed = self.pending.popleft()
            self._apply(label, t_confirmed)

    def observe(self, sighting: Sighting) -> None:
        """Feed one label; name the first terrain, apply or schedule a confirmed change."""
        where = self.travelled + (sighting.ahead if self.on_arrival else 0.0)
        confirmed = self.tracker.observe(sighting.label, at=where)
        if self.ekf.terrain is None:
            self.ekf.set_terrain(self.tracker.current or sighting.label)
            return
        if confirmed is None:
            return
        target = float(self.tracker.changed_at)  # type: ignore[arg-type] - set with every `at`
        if target > self.travelled:
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
