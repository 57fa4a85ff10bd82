"""The ICR EKF's pose gate: its chi-square bounds, and ``reset_pose`` forgetting rejections in a row.

Written for mutants of ``estimation/icr_ekf.py`` no test killed
(docs/testing.md): the heading bound doubled instead of squared or taken at
the lower quantile (only a docstring example stated it), and ``reset_pose``
leaving a count of rejections in a row behind.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.stats import chi2

from terrain_odom.config import EkfConfig, PoseGate, TerrainConfig
from terrain_odom.estimation import IcrEkf
from terrain_odom.estimation.icr_ekf import gate_bounds


@pytest.mark.parametrize("p", [0.5, 0.9, 0.999, 0.9999])
def test_gate_bounds_are_the_chi_square_quantiles(p):
    position, heading = gate_bounds(PoseGate(probability=p, headings=True))
    assert position == pytest.approx(chi2.ppf(p, 2), rel=1e-9)
    assert heading == pytest.approx(chi2.ppf(p, 1), rel=1e-9)
    assert gate_bounds(PoseGate(probability=p))[1] == math.inf  # headings not gated
    assert gate_bounds(PoseGate(enabled=False, probability=p)) == (math.inf, math.inf)


def _ekf(reacquire_after: int) -> IcrEkf:
    gate = PoseGate(reacquire_after=reacquire_after, reacquire=1e9)
    return IcrEkf(dataclasses.replace(EkfConfig(), gate=gate), TerrainConfig())


def test_reset_pose_forgets_the_rejections_in_a_row():
    jump = [50.0, 0.0, np.nan]  # a position far beyond the gate
    ekf = _ekf(reacquire_after=2)
    assert math.isnan(ekf.update(jump)) and ekf.gating[2] == 1.0  # rejected, one in a row
    ekf.reset_pose([0.0, 0.0, 0.0])
    assert math.isnan(ekf.gating[0]) and math.isnan(ekf.gating[1])
    assert ekf.gating[2:4].tolist() == [0.0, 0.0]
    assert ekf.gating[4] == 1.0  # the total of rejected positions is kept
    # counting starts again: two more rejections in a row before the next is fused
    assert math.isnan(ekf.update(jump)) and math.isnan(ekf.update(jump))
    assert not math.isnan(ekf.update(jump)) and ekf.gating[6] == 1.0  # re-acquired
