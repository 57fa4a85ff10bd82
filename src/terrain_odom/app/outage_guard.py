"""The run's guard: whether the learned model carries the robot through pose outages better.

A filter that learns its model online must never end worse than the model
it started from. :class:`OutageGuard` keeps the ICR EKF's state at the
start rows of the outage windows of the log while the run streams
(:meth:`OutageGuard.add`, one block of rows at a time), then dead-reckons the
learned model (the state at each start), the nominal one (the first row's)
and the ideal differential drive through 30-s and 60-s outages
(:func:`~terrain_odom.evaluation.outage.frozen_icr_table`) and says which is
better: a section of ``report.json`` and ``report.md``, lines of the
printout, and one warning when the learned model is worse.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from terrain_odom.config import Config
from terrain_odom.estimation.odometry import OdometryBlock
from terrain_odom.evaluation.outage import (
    DEFAULT_OUTAGES,
    OUTAGE_EVERY,
    OutageErrors,
    frozen_icr_table,
    outage_spacing,
    outage_starts,
)
from terrain_odom.evaluation.sparse import antenna_of
from terrain_odom.records import WheelLog
from terrain_odom.reporting.outage import OutageSection

__all__ = ["GUARD_STATES", "OutageGuard", "GuardResult"]

GUARD_STATES = ("yaw", "y_l", "y_r", "x_icr", "alpha")
"""The filter states the guard keeps at each outage start (``alpha`` 1 when not estimated)."""


@dataclass(frozen=True)
class GuardResult:
    """What the guard found.

    Attributes
    ----------
    outages : dict of float to dict of str to OutageErrors
        Per duration, ``learned``, ``nominal`` and ``idd`` (empty when skipped).
    skipped : str or None
        Why there was nothing to compare (no positions, log too short, slip EKF).
    seconds : float
        Time the guard took, s (keeping the states and the comparison).
    every : float
        Time between window starts, s (:func:`~terrain_odom.evaluation.outage.outage_spacing`).
    """

    outages: dict[float, dict[str, OutageErrors]] = field(default_factory=dict)
    skipped: str | None = None
    seconds: float = 0.0
    every: float = OUTAGE_EVERY

    def worse(self) -> list[tuple[float, float, float]]:
        """Durations where the learned model's median error exceeds the nominal's: ``(s, m, m)``."""
        found = []
        for duration, models in self.outages.items():
            learned = models["learned"].position_stats.median
            nominal = models["nominal"].position_stats.median
            if learned > nominal:
                found.append((duration, learned, nominal))
        return found

    def warnings(self) -> list[str]:
        """One line when the learned model dead-reckons worse than the nominal one (else none)."""
        worse = self.worse()
        if not worse:
            return []
        parts = ", ".join(f"{d:g} s: {a:.2f} m vs {b:.2f} m" for d, a, b in worse)
        return [
            f"the learned model dead-reckons worse than the nominal one it started from through "
            f"pose outages (median displacement error, {parts}): it has absorbed something "
            "other than the robot's skid (antenna lever arm, pose delay, understated pose "
            "noise?); see the report's outage section"
        ]

    def lines(self) -> list[str]:
        """Return the printout: one line per duration (or why the guard was skipped)."""
        if self.skipped is not None:
            return [f"skipped: {self.skipped}"]
        out = []
        for duration, models in self.outages.items():
            n = len(models["learned"].windows)
            medians = ", ".join(
                f"{name} {e.position_stats.median:.2f} m" for name, e in models.items()
            )
            out.append(f"{duration:g} s outages ({n}): {medians} (median displacement error)")
        return out

    def section(self) -> OutageSection:
        """Return the ``outage_guard`` section of the report (the same on every run of a log)."""
        if self.skipped is not None:
            return OutageSection(skipped=self.skipped)
        worse = tuple(d for d, _, _ in self.worse())
        return OutageSection(self.outages, self.every, learned_worse_s=worse)


class OutageGuard:
    """Keeps a run's states at the outage starts of its log, then compares the models.

    Parameters
    ----------
    log : WheelLog
        The log the run streams (pose delay applied).
    config : Config
        The run's configuration (track width, ``pose_sensor`` antenna).
    names : tuple of str
        The estimator's state names (the columns of its blocks).
    estimator : str
        ``"icr-ekf"`` or ``"slip-ekf"`` (skipped: its model is not an ICR state).
    """

    def __init__(
        self, log: WheelLog, config: Config, names: tuple[str, ...], estimator: str
    ) -> None:
        started = time.perf_counter()
        self.log, self.config = log, config
        self.durations = DEFAULT_OUTAGES
        self.skipped = self._why_not(log, names, estimator)
        self.starts = np.zeros(0, dtype=int) if self.skipped else outage_starts(log, self.durations)
        if self.skipped is None and self.starts.size == 0:
            self.skipped = (
                f"no {self.durations[0]:g} s stretch between position fixes of one segment"
            )
        self.columns = [names.index(n) if n in names else -1 for n in GUARD_STATES]
        self.states = np.ones((self.starts.size, len(GUARD_STATES)))
        self.first = np.ones(len(GUARD_STATES))
        self.seconds = time.perf_counter() - started

    @staticmethod
    def _why_not(log: WheelLog, names: tuple[str, ...], estimator: str) -> str | None:
        if estimator != "icr-ekf":
            return (
                f"the guard freezes ICR EKF states; a {estimator} run's model is its slip "
                "parameters ('evaluate --run DIR --outage 30s 60s' scores it)"
            )
        if not log.has_position.any():
            return "no position measurements in the log (a wheel-only run): nothing to compare with"
        missing = [n for n in GUARD_STATES[:4] if n not in names]
        return f"the estimator has no {missing} state" if missing else None

    def _take(self, states: np.ndarray) -> np.ndarray:
        taken = np.ones((states.shape[0], len(GUARD_STATES)))
        for k, c in enumerate(self.columns):
            if c >= 0:
                taken[:, k] = states[:, c]
        return taken

    def add(self, block: OdometryBlock) -> None:
        """Keep the states of the block's rows that start an outage window (and the first row's)."""
        if self.skipped is not None:
            return
        started = time.perf_counter()
        if block.start == 0:
            self.first = self._take(block.states[:1])[0]
        lo, hi = np.searchsorted(self.starts, [block.start, block.start + block.t.size])
        if hi > lo:
            self.states[lo:hi] = self._take(block.states[self.starts[lo:hi] - block.start])
        self.seconds += time.perf_counter() - started

    def result(self) -> GuardResult:
        """Compare the learned, nominal and idd models through the outages."""
        if self.skipped is not None:
            return GuardResult(skipped=self.skipped, seconds=self.seconds)
        started = time.perf_counter()
        table = frozen_icr_table(
            self.log,
            self.durations,
            self.starts,
            self.states,
            self.first[1:5],
            track_width=self.config.robot.track_width,
            antenna=antenna_of(self.config),
        )
        seconds = self.seconds + time.perf_counter() - started
        return GuardResult(table, seconds=seconds, every=outage_spacing(self.log))
