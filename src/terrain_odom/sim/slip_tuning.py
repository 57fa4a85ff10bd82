"""Slip-EKF tuning for the Sec. 4.1 simulation (:func:`~terrain_odom.sim.slip_scenario.icr_switch_scenario`).

Pose at 10 Hz with RTK-GPS noise; the 2016 paper's model has no ``alpha``.
``window``, ``sigma_p0`` and ``sigma_q`` were chosen on seeds 100-109;
``bench/slip_ekf.py`` reports seeds 0-9 and the tests use the same tuning.
"""

from __future__ import annotations

from terrain_odom.config import (
    Config,
    PoseChangeSigmas,
    RobotConfig,
    SlipEkfConfig,
    SlipSigmas,
    TerrainConfig,
)
from terrain_odom.sim.slip_scenario import TRACK_WIDTH

__all__ = ["SEC41_SLIP_EKF", "sec41_config"]

SEC41_SLIP_EKF = SlipEkfConfig(
    estimate_alpha=False,
    window=0.6,
    sigma_p0=SlipSigmas(*(2.0,) * 6, 0.1),
    sigma_pb=SlipSigmas(*(2.0,) * 6, 0.1),
    sigma_q=SlipSigmas(*(0.12,) * 6, 0.001),
    sigma_r=PoseChangeSigmas(0.03, 0.03, 0.012),
)


def sec41_config(adapt: bool = True) -> Config:
    """Return the configuration of the slip EKF on the Sec. 4.1 scenario.

    Parameters
    ----------
    adapt : bool
        Reset the filter at the (signalled) terrain changes; False leaves
        the changes unsignalled, as in the paper.

    Returns
    -------
    Config
        Track width :data:`~terrain_odom.sim.slip_scenario.TRACK_WIDTH` (m),
        :data:`SEC41_SLIP_EKF`, terrain memory off.
    """
    return Config(
        robot=RobotConfig(track_width=TRACK_WIDTH),
        slip_ekf=SEC41_SLIP_EKF,
        terrain=TerrainConfig(adapt=adapt, memory=False),
    )
