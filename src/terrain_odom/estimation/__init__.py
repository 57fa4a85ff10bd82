"""Online estimation: ICR EKF, slip-parameter EKF, terrain tracker, OnlineOdometry.

Imported here: the ICR EKF, its process step (:mod:`~terrain_odom.estimation.icr_model`)
and the terrain tracker; the
rest from their own modules (:mod:`~terrain_odom.estimation.slip_ekf`,
:mod:`~terrain_odom.estimation.online`, the row loop over a log in
:mod:`~terrain_odom.estimation.odometry`, pose-delay estimation in
:mod:`~terrain_odom.estimation.time_offset`).
"""

from terrain_odom.estimation.icr_ekf import IcrEkf, IcrPriors
from terrain_odom.estimation.icr_model import (
    STATE_NAMES,
    icr_step,
    icr_step_jacobian,
    icr_step_with_jacobian,
    state_names,
)
from terrain_odom.estimation.terrain import TerrainTracker
from terrain_odom.records import TerrainChange

__all__ = [
    "STATE_NAMES",
    "IcrEkf",
    "IcrPriors",
    "TerrainChange",
    "TerrainTracker",
    "icr_step",
    "icr_step_jacobian",
    "icr_step_with_jacobian",
    "state_names",
]
