"""Fixtures of the estimation tests: the EKFs' kernels run as Python or compiled."""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.estimation import _kalman_kernels, _kernel_switch, _kernels, _slip_kernels

TOLERANCE = 1e-12
"""How far the compiled filters may be from their references."""


def python_kernels(monkeypatch: pytest.MonkeyPatch) -> None:
    """Put the kernels of both filters back as a fresh process has them: Python, counting calls."""
    monkeypatch.setattr(_kernel_switch, "_compiled", False)
    monkeypatch.setattr(_kernel_switch, "_calls", 0)
    for name, function in _kalman_kernels.KERNELS.items():
        monkeypatch.setattr(_kalman_kernels, name, function)
    for module in (_kernels, _slip_kernels):
        for name, function in {**module.KERNELS, **module._WRAPPERS}.items():
            monkeypatch.setattr(module, name, function)


@pytest.fixture
def kernels(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Run the kernels as Python (as the first calls of a process do), or compiled.

    Parametrise indirectly with ``"python"`` or ``"compiled"``.
    """
    if request.param == "compiled":
        _kernel_switch.compile_kernels()
    else:
        python_kernels(monkeypatch)
        monkeypatch.setattr(_kernel_switch, "PURE_CALLS", 10**12)
    return str(request.param)


def assert_equal_runs(fast: object, slow: object) -> None:
    """Two runs' results (``OdometryResult``) agree to :data:`TOLERANCE`, updates and changes alike."""
    assert fast.n_updates == slow.n_updates > 0  # type: ignore[attr-defined]
    assert fast.changes == slow.changes  # type: ignore[attr-defined]
    for name in ("states", "stds"):
        np.testing.assert_allclose(
            getattr(fast, name), getattr(slow, name), rtol=0, atol=TOLERANCE, err_msg=name
        )
