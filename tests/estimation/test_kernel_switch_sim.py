"""The switch from Python to compiled kernels mid-run, on the shipped simulated run (no ../shared).

The twin of ``test_switch_to_compiled_kernels_mid_run_changes_no_bit`` in
``test_icr_ekf_kernel.py``, which needs the real logs.
"""

from __future__ import annotations

import numpy as np

from terrain_odom.config import load_config
from terrain_odom.estimation import _kernel_switch, _kernels, odometry
from terrain_odom.io import read_wheel_log

from .conftest import python_kernels


def test_switch_to_compiled_kernels_mid_run_changes_no_bit_on_the_simulated_run(
    sample_dir, monkeypatch
):
    cfg = load_config(sample_dir / "config.yaml")
    log = read_wheel_log(sample_dir / "log.csv", wheel_radius=cfg.robot.wheel_radius)
    _kernel_switch.compile_kernels()
    compiled = odometry.run_icr_ekf(log, cfg, labels=log.terrain)
    python_kernels(monkeypatch)
    monkeypatch.setattr(_kernel_switch, "PURE_CALLS", 300)
    switched = odometry.run_icr_ekf(log, cfg, labels=log.terrain)
    assert _kernel_switch._compiled and _kernels.icr_predict is _kernels._icr_predict  # switched
    assert len(compiled.changes) >= 2  # resets and memory on both sides of the switch
    np.testing.assert_array_equal(switched.states, compiled.states)
    np.testing.assert_array_equal(switched.stds, compiled.stds)
