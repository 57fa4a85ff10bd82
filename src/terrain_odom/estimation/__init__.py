"""Online estimators: the ICR EKF and the terrain change tracker."""

from terrain_odom.estimation.icr_ekf import (
    STATE_NAMES,
    IcrEkf,
    IcrPriors,
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
