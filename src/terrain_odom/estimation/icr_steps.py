"""The ICR EKF's steps in the stream: predict every wheel sample, anchor, then update.

:class:`IcrSteps` is the :class:`~terrain_odom.estimation.steps.FilterSteps`
of :class:`~terrain_odom.estimation.online.OnlineOdometry` with
``estimator="icr-ekf"`` (Chen et al. 2023).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from terrain_odom.estimation.pose_measurement import PoseUse
from terrain_odom.estimation.steps import HEADING, POSITION, YAW
from terrain_odom.kinematics import wrap_angle
from terrain_odom.kinematics.mounting import robot_pose, sensor_pose

if TYPE_CHECKING:
    from terrain_odom.estimation.icr_ekf import IcrEkf
    from terrain_odom.estimation.steps import RowBatch

__all__ = ["IcrSteps"]


class IcrSteps:
    """The ICR EKF: predict every wheel sample, anchor then update at poses.

    Each segment anchors the heading at its first measured heading and the
    position at its first position once the heading is known. Without a
    measured heading (a GPS alone), the heading is taken from the course:
    the first fix anchors the position in a provisional frame, the fixes
    after it keep the position within two ``sigma_r`` of them (no dead
    reckoning far on a heading not yet known), and once a fix lies
    ``min_course`` m from the first the frame
    is turned so that the filter's dead-reckoned antenna displacement
    points along the measured one. Only then do fixes update the filter.
    """

    def __init__(self, ekf: IcrEkf) -> None:
        self.filter = ekf
        self.names = ekf.names
        sig = ekf.config.sigma_r
        self._r = np.array([sig.x, sig.y, sig.yaw])
        self._min_course = max(1.0, 10.0 * max(sig.x, sig.y))
        self.restart(0.0)

    def restart(self, t: float) -> None:
        """Start a segment at ``t`` (s): heading and position are anchored again."""
        self._heading = self._position = False  # a break: nothing is integrated across it
        self._course: tuple[np.ndarray, np.ndarray] | None = None  # first fix, its prediction
        self.filter.t = t

    @property
    def anchored(self) -> bool:
        """Whether heading and position are anchored: every pose component is fused."""
        return self._heading and self._position

    def predict(self, v_l: float, v_r: float, dt: float) -> None:
        """Predict over ``dt`` s with the track speeds ``v_l, v_r`` (m/s) held."""
        self.filter.predict(v_l, v_r, dt)

    def sample(self, t: float, v_l: float, v_r: float) -> None:
        """Nothing to keep: the ICR EKF predicts sample by sample."""

    def measure(self, z: np.ndarray, rows: tuple[int, ...], use: PoseUse) -> bool:
        """Fuse the ``rows`` components of pose ``z``; return whether the filter updated."""
        position, heading = 0 in rows, YAW in rows  # components left to fuse
        if heading and not self._heading:
            self._anchor(z, heading=True)
            heading = False
            use.used(HEADING)
        if position and not self._position:
            position = False
            if self._heading:
                self._anchor(z, heading=False)
                use.used(POSITION)
            else:
                self._course_heading(z)
                use.used(POSITION)
        if not (position or heading):
            return False
        nan = math.nan
        x, y, yaw = z.tolist()
        counted = self.filter.gating[4:].copy()
        nis = self.filter.update(np.array([x if position else nan, y if position else nan,
                                           yaw if heading else nan]))  # fmt: skip
        if position:
            use.used(POSITION)
        if heading:
            use.used(HEADING)
        use.gated(self.filter.gating[4:] - counted)
        return not math.isnan(nis)

    def _anchor(self, z: np.ndarray, *, heading: bool) -> None:
        """Reset the heading (``heading``) or the position to the measured one."""
        ekf = self.filter
        if heading:
            ekf.anchor_heading(z[YAW], self._r[YAW])
            self._heading = True
            self._course = None  # a provisional frame of the course is no longer needed
            return
        pose, sigma = ekf.pose, ekf.std[:3]
        pose[:2] = robot_pose(z, ekf.mounting, yaw=pose[YAW])[:2]
        sigma[:2] = self._r[:2]
        self._position = True
        ekf.reset_pose(pose, sigma)

    def _course_heading(self, z: np.ndarray) -> None:
        """Take the heading from the course between fixes (no heading measured yet).

        The first fix anchors the position in a provisional frame (the
        heading as it was); until a fix lies ``min_course`` m from the
        first, whose chord turns the frame, a fix more than two ``sigma_r``
        from the dead-reckoned position resets it to the fix.
        """
        ekf = self.filter
        predicted = sensor_pose(ekf.pose, ekf.mounting)[:2]
        if self._course is None:
            ekf.reset_pose(robot_pose(z, ekf.mounting, yaw=ekf.pose[YAW]), ekf.std[:3])
            self._course = (z[:2].copy(), sensor_pose(ekf.pose, ekf.mounting)[:2])
            return
        measured = z[:2] - self._course[0]
        moved = predicted - self._course[1]
        distance = float(np.hypot(*measured))
        if distance < self._min_course or not np.hypot(*moved) > 0.5 * distance:
            # Not far enough yet. Dead reckoning on the provisional heading would draw an
            # excursion: the position is held to the fix once two sigma_r off it, the frame's
            # origin moved with it (the dead-reckoned chord is kept).
            if np.hypot(*(predicted - z[:2])) > 2.0 * max(self._r[:2]):
                ekf.reset_pose(robot_pose(z, ekf.mounting, yaw=ekf.pose[YAW]), ekf.std[:3])
                self._course = (self._course[0], self._course[1] - predicted + z[:2])
            return
        turn = np.arctan2(measured[1], measured[0]) - np.arctan2(moved[1], moved[0])
        yaw = float(wrap_angle(ekf.pose[YAW] + turn))
        sigma = ekf.std[:3]
        sigma[:2] = self._r[:2]
        sigma[YAW] = np.hypot(2.0 * max(self._r[:2]) / distance, 0.1)  # fix noise, path shape
        ekf.reset_pose(robot_pose(z, ekf.mounting, yaw=yaw), sigma)
        self._heading = self._position = True

    def icr_params(self, v_l: float, v_r: float) -> np.ndarray:
        """Return the current ``y_l, y_r, x_icr(, alpha)``: the same at any track speeds."""
        return self.filter.params

    def estimate(self, v_l: float, v_r: float) -> tuple[np.ndarray, np.ndarray]:
        """Return the state and its standard deviation, in :attr:`names` order."""
        return self.filter.x, self.filter.std

    def batch(self) -> RowBatch | None:
        """Run rows in one compiled call once heading and position are anchored."""
        return self._run_rows if self.anchored else None

    def _run_rows(
        self,
        since: tuple[float, float, float],
        t: np.ndarray,
        speeds: tuple[np.ndarray, np.ndarray],
        pose: np.ndarray,
        use: PoseUse,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        """Run rows through :meth:`~terrain_odom.estimation.icr_ekf.IcrEkf.run_rows`.

        The ICR parameters after each row are the states' columns after the pose's.
        """
        ekf = self.filter
        counted = ekf.gating[4:].copy()
        states, stds, updates = ekf.run_rows(since, t, speeds, pose)
        use.fused(pose)
        use.gated(ekf.gating[4:] - counted)
        return states, stds, states[:, YAW + 1 : YAW + 1 + ekf.params.size], updates
