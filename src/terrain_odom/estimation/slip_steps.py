"""The slip EKF's steps in the stream: dead reckoning, windowed pose changes, chords.

:class:`SlipSteps` is the :class:`~terrain_odom.estimation.steps.FilterSteps`
of :class:`~terrain_odom.estimation.online.OnlineOdometry` with
``estimator="slip-ekf"``.
"""

from __future__ import annotations

from collections import deque
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from terrain_odom.estimation.pose_measurement import PoseUse
from terrain_odom.estimation.steps import HEADING, POSITION, YAW
from terrain_odom.kinematics import relative_pose, wrap_angle
from terrain_odom.kinematics.mounting import Mounting, robot_pose

if TYPE_CHECKING:
    from terrain_odom.estimation.slip_ekf import SlipEkf
    from terrain_odom.estimation.steps import RowBatch

__all__ = ["SlipSteps"]

_HEADING_AGE = 1.0  # s: the slip EKF's dead-reckoned heading older than this orients no position
_CLOSE_FIX = "no heading, and within a quarter chord of the previous fix (standing)"


class _Anchor(NamedTuple):
    """A measured pose a later pose change is measured from."""

    t: float
    pose: np.ndarray  # robot pose, unmeasured components dead-reckoned
    sample: int  # number of its wheel sample in the segment


class _CourseFixes:
    """Fixes without a heading, for the slip EKF: two chords of at least ``length`` m.

    A GPS alone fixes the path up to a rotation: from the fixes ``b, a, k``
    it measures the length of the chord ``a -> k`` and its turn from the
    chord ``b -> a`` (:func:`~terrain_odom.estimation.pose_measurement.chord_turn`),
    ``a`` the latest fix at least ``length`` m from ``k``, ``b`` the latest
    at least ``length`` m from ``a``. A fix within a quarter chord of the
    previous one kept is not kept (a standing robot keeps the buffer short).
    """

    def __init__(self, length: float, sigma: float) -> None:
        self.length = length
        self.sigma = sigma  # noise of a position change, m
        self.fixes: deque[tuple[np.ndarray, int]] = deque()  # (antenna x, y; wheel sample)

    def clear(self) -> None:
        self.fixes.clear()

    def add(
        self, xy: np.ndarray, sample: int
    ) -> tuple[bool, tuple[tuple[np.ndarray, int], tuple[np.ndarray, int]] | None]:
        """Keep a fix (unless too close); return whether kept, and the fixes ``b, a`` if any."""
        fixes = self.fixes
        if fixes and np.hypot(*(xy - fixes[-1][0])) < 0.25 * self.length:
            return False, None
        a = self._latest_away(xy, len(fixes))
        b = None if a is None else self._latest_away(fixes[a][0], a)
        pair = None if a is None or b is None else (fixes[b], fixes[a])
        for _ in range(b or 0):
            fixes.popleft()  # never an anchor again (unless the robot comes back)
        fixes.append((xy.copy(), sample))
        return True, pair

    def _latest_away(self, xy: np.ndarray, before: int) -> int | None:
        """Return the index of the latest fix before ``before`` at least a chord from ``xy``."""
        for k in range(before - 1, -1, -1):
            if np.hypot(*(xy - self.fixes[k][0])) >= self.length:
                return k
        return None

    def measured(
        self, xy_b: np.ndarray, xy_a: np.ndarray, xy_k: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Return the measured ``(length of a -> k, turn from b -> a)`` and their variances."""
        first, second = xy_a - xy_b, xy_k - xy_a
        l1, l2 = np.hypot(*first), np.hypot(*second)
        turn = wrap_angle(np.arctan2(second[1], second[0]) - np.arctan2(first[1], first[0]))
        return np.array([l2, turn]), self.sigma**2 * np.array([1.0, 1.0 / l1**2 + 1.0 / l2**2])


class SlipSteps:
    """The slip EKF: a windowed pose change at every measured pose component.

    The measured components are turned into the robot's (heading offset,
    antenna lever arm at the measured or else dead-reckoned heading). A
    heading updates with the heading change since its anchor: the latest
    earlier heading of the same segment at least ``slip_ekf.window``
    seconds before (0: the previous one), or the segment's first one while
    the segment is shorter; a position likewise with the position change
    since its anchor among the positions, in the frame of the robot there
    (its heading measured, or dead-reckoned from one measured at most 1 s
    before). Where both anchors are one row, the whole pose change is one
    update. A position with no heading that recent (a GPS alone; the
    heading is no state of the slip EKF, and dead reckoning drifts) updates
    with what positions alone measure: a chord's length and its turn from
    the chord before (:class:`_CourseFixes`). The wheel
    samples since the oldest anchor still needed are kept (a bounded
    buffer: the window plus the gap between measurements). The reported
    pose (``x, y, yaw``) is dead reckoning with the current parameters from
    the origin at each segment start, reset to every measured pose component.
    """

    def __init__(self, ekf: SlipEkf, mounting: Mounting) -> None:
        from terrain_odom.estimation.slip_ekf import OUTPUT_NAMES

        self.filter = ekf
        self.names = OUTPUT_NAMES + ekf.names
        self.mounting = mounting
        self._window = ekf.config.window
        self._anchors: dict[str, deque[_Anchor]] = {POSITION: deque(), HEADING: deque()}
        self._samples: deque[tuple[float, float, float]] = deque()  # (t, v_l, v_r)
        sigma = ekf.config.sigma_r.dx
        self._course = _CourseFixes(max(0.5, 10.0 * sigma), sigma)
        self.restart(0.0)

    def restart(self, t: float) -> None:
        """Start a segment at ``t`` (s): anchors, fixes, samples and pose start afresh."""
        for chain in self._anchors.values():
            chain.clear()
        self._course.clear()
        self._samples.clear()
        self._first = 0  # number of self._samples[0] in the segment
        self._pose = np.zeros(3)
        self._headed = -np.inf  # time of the segment's latest measured heading, s
        self.filter.t = t

    def predict(self, v_l: float, v_r: float, dt: float) -> None:
        """Predict the parameters and dead-reckon the pose over ``dt`` s."""
        self.filter.predict(dt)
        self.filter.dead_reckon(self._pose, v_l, v_r, dt)

    def sample(self, t: float, v_l: float, v_r: float) -> None:
        """Keep the wheel sample; forget those no anchor needs any more."""
        self._samples.append((t, v_l, v_r))
        self._drop_samples(self._oldest_needed())

    def _oldest_needed(self) -> int:
        """Return the number of the oldest wheel sample an anchor still needs (else the newest)."""
        firsts = [chain[0].sample for chain in self._anchors.values() if chain]
        if self._course.fixes:
            firsts.append(self._course.fixes[0][1])
        return min(firsts, default=self._first + len(self._samples) - 1)

    def _drop_samples(self, first: int) -> None:
        """Forget the wheel samples before sample number ``first``."""
        while self._first < first:
            self._samples.popleft()
            self._first += 1

    def measure(self, z: np.ndarray, rows: tuple[int, ...], use: PoseUse) -> bool:
        """Fuse the ``rows`` components of pose ``z``; return whether the filter updated."""
        has_position, has_heading = 0 in rows, YAW in rows
        t = self._samples[-1][0]
        if has_heading:
            self._pose[YAW] = wrap_angle(z[YAW] - self.mounting.heading_offset)
            self._headed = t
        if has_position:
            self._pose[:2] = robot_pose(z, self.mounting, yaw=self._pose[YAW])[:2]
        sample = self._first + len(self._samples) - 1
        course = has_position and t - self._headed > _HEADING_AGE
        updated = course and self._course_update(z[:2], sample, use)
        here = _Anchor(t, self._pose.copy(), sample)
        froms = {
            what: self._anchor(what, here)
            for what, measured in (
                (POSITION, has_position and not course),
                (HEADING, has_heading),
            )
            if measured
        }
        for what in froms:
            use.used(what)
        self._drop_samples(self._oldest_needed())
        changes = self._changes(froms)
        for anchor, mask in changes:
            self._update(anchor, here, mask)
        return bool(changes) or updated

    def _course_update(self, xy: np.ndarray, sample: int, use: PoseUse) -> bool:
        """Fuse a fix without a heading as the end of two chords (see :class:`_CourseFixes`)."""
        kept, pair = self._course.add(xy, sample)
        if not kept:
            use.drop(POSITION, _CLOSE_FIX)
            return False
        use.used(POSITION)
        if pair is None:
            return False
        (xy_b, b), (xy_a, a) = pair
        z, variances = self._course.measured(xy_b, xy_a, xy)
        samples = np.array(self._samples)
        first, second = (
            samples[start - self._first : end - self._first + 1].T
            for start, end in ((b, a), (a, sample))
        )
        self.filter.update_course(
            z,
            (first[1][:-1], first[2][:-1], np.diff(first[0])),
            (second[1][:-1], second[2][:-1], np.diff(second[0])),
            self.mounting.antenna,
            variances,
        )
        return True

    def _anchor(self, what: str, here: _Anchor) -> _Anchor | None:
        """Return the anchor of a ``what`` measured ``here`` (None: the first); chain ``here``."""
        chain = self._anchors[what]
        while len(chain) > 1 and chain[1].t <= here.t - self._window:
            chain.popleft()  # never needed again
        anchor = chain[0] if chain else None
        chain.append(here)
        return anchor

    @staticmethod
    def _changes(froms: dict[str, _Anchor | None]) -> list[tuple[_Anchor, np.ndarray]]:
        """Return the pose changes to fuse, ``(anchor, components)``: one where anchors agree."""
        position, heading = froms.get(POSITION), froms.get(HEADING)
        if position is not None and heading is not None and position.sample == heading.sample:
            return [(position, np.ones(3, dtype=bool))]
        out = []
        if position is not None:
            out.append((position, np.array([True, True, False])))
        if heading is not None:
            out.append((heading, np.array([False, False, True])))
        return out

    def _update(self, anchor: _Anchor, here: _Anchor, mask: np.ndarray) -> None:
        """Fuse the change of the ``mask`` components from ``anchor`` to ``here``."""
        samples = np.array(self._samples)
        t, v_l, v_r = samples[anchor.sample - self._first : here.sample - self._first + 1].T
        change = np.where(mask, relative_pose(anchor.pose, here.pose), np.nan)
        self.filter.update(change, v_l[:-1], v_r[:-1], np.diff(t))

    def icr_params(self, v_l: float, v_r: float) -> np.ndarray:
        """Return the ICRs at track speeds ``v_l, v_r`` (m/s) and ``alpha`` (1: none)."""
        icr = self.filter.icrs(v_l, v_r)
        alpha = self.filter.x[6] if len(self.filter.names) > 6 else 1.0
        return np.array([*map(float, icr), alpha])

    def estimate(self, v_l: float, v_r: float) -> tuple[np.ndarray, np.ndarray]:
        """Return the outputs and their standard deviations at track speeds ``v_l, v_r``."""
        return self.filter.estimate(self._pose, v_l, v_r)

    def batch(self) -> RowBatch | None:
        """None: the slip EKF runs rows one by one."""
        return None
