"""Fixtures of the estimation tests: the ICR EKF's kernels run as Python or compiled."""

from __future__ import annotations

import pytest

from terrain_odom.estimation import _kernels


def python_kernels(monkeypatch: pytest.MonkeyPatch) -> None:
    """Put the kernels back as a fresh process has them: Python, counting calls."""
    monkeypatch.setattr(_kernels, "_compiled", False)
    monkeypatch.setattr(_kernels, "_calls", 0)
    for name, function in {**_kernels._PURE, **_kernels._WRAPPERS}.items():
        monkeypatch.setattr(_kernels, name, function)


@pytest.fixture
def kernels(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Run the kernels as Python (as the first calls of a process do), or compiled.

    Parametrise indirectly with ``"python"`` or ``"compiled"``.
    """
    if request.param == "compiled":
        _kernels.compile_kernels()
    else:
        python_kernels(monkeypatch)
        monkeypatch.setattr(_kernels, "PURE_CALLS", 10**12)
    return str(request.param)
