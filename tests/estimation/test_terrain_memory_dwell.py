"""Terrain memory remembers a terrain only after a stay of ``memory_min_dwell`` seconds.

Mutation testing found ``memory_min_dwell`` could be ignored without any
test noticing ("short stay: asphalt2 not remembered later" was a comment,
not an assertion). A short stay is not remembered: coming back to that
terrain resets to ``P_B``; a stay of at least the dwell is restored.
"""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.config import EkfConfig, IcrSigmas, TerrainConfig
from terrain_odom.estimation import IcrEkf

DWELL = 5.0
PB = IcrSigmas(0.4, 0.3, 0.2, 0.05)


def _stay(ekf: IcrEkf, seconds: float, dt: float = 0.25) -> None:
    """Drive an arc for ``seconds`` (wheel samples of ``dt``), no pose update."""
    for _ in range(round(seconds / dt)):
        ekf.predict(0.8, 1.2, dt)


def _filter() -> IcrEkf:
    ekf = IcrEkf(EkfConfig(sigma_pb=PB), TerrainConfig(memory=True, memory_min_dwell=DWELL))
    ekf.set_terrain("grass")
    _stay(ekf, 20.0)
    return ekf


def _p_b() -> np.ndarray:
    return np.diag(np.square([PB.y_l, PB.y_r, PB.x_icr, PB.alpha]))


@pytest.mark.parametrize(("stay", "remembered"), [(DWELL - 0.25, False), (DWELL, True)])
def test_a_terrain_is_remembered_only_after_the_minimum_dwell(stay, remembered):
    ekf = _filter()
    ekf.reset_on_terrain_change("asphalt")
    _stay(ekf, stay)  # the ICR covariance grows from P_B by the random walk meanwhile
    asphalt_cov = ekf.P[3:, 3:]
    assert not np.allclose(asphalt_cov, _p_b())
    ekf.reset_on_terrain_change("gravel")
    _stay(ekf, 20.0)
    change = ekf.reset_on_terrain_change("asphalt")
    assert change.restored is remembered
    if remembered:
        np.testing.assert_array_equal(ekf.P[3:, 3:], asphalt_cov)
    else:  # reset to P_B as on a first visit
        np.testing.assert_allclose(ekf.P[3:, 3:], _p_b())


def test_short_stay_is_not_remembered_but_the_terrain_before_it_is():
    """The sequence of ``test_terrain_memory_restores_converged_estimate``, asserted."""
    ekf = _filter()
    grass = ekf.params
    ekf.reset_on_terrain_change("asphalt")
    _stay(ekf, 20.0)
    ekf.reset_on_terrain_change("asphalt2")
    _stay(ekf, 0.25)  # short stay
    back = ekf.reset_on_terrain_change("grass")
    assert back.restored
    np.testing.assert_array_equal(ekf.params, grass)
    _stay(ekf, 20.0)
    again = ekf.reset_on_terrain_change("asphalt2")
    assert (again.previous, again.label, again.restored) == ("grass", "asphalt2", False)
    np.testing.assert_allclose(ekf.P[3:, 3:], _p_b())
    _stay(ekf, 20.0)
    assert ekf.reset_on_terrain_change("asphalt").restored  # 20 s there: remembered
