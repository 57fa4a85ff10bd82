"""The switch of the EKFs' compiled kernels: Python for a process's first calls, then numba.

``cache=True`` keeps the machine code in ``__pycache__``, so only the first
process after an install (or a change of a kernel's file) compiles (~2-4 s);
later ones load it. Importing numba and loading the kernels still costs a
process ~0.5-0.9 s, more than a short log takes in plain Python: the first
:data:`PURE_CALLS` kernel calls run the kernels as Python (~0.1-0.3 ms a
call, numpy's errors off like numba's ``error_model="numpy"``), and only then
are they compiled (:func:`compile_kernels`), so a short run never imports
numba. A kernel module (:mod:`~terrain_odom.estimation._kalman_kernels`,
:mod:`~terrain_odom.estimation._kernels`,
:mod:`~terrain_odom.estimation._slip_kernels`) joins the switch with
:func:`register`: one count of calls, one compilation. The switch points the
module's kernel names (its ``globals()``) at the compiled functions, since
numba resolves a kernel's calls of other kernels through those names.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

__all__ = ["PURE_CALLS", "compile_kernels", "register"]

PURE_CALLS = 2000
"""Kernel calls run as Python before the kernels are compiled (about 700-1000 log rows)."""

_MODULES: list[tuple[dict[str, Any], dict[str, Callable[..., Any]], tuple[str, ...]]] = []
"""Every module's kernels: its namespace, its kernels as Python by name, its public names."""
_DISPATCHERS: dict[Callable[..., Any], Callable[..., Any]] = {}  # Python function -> numba's
_calls = 0  # kernel calls run as Python so far (all modules)
_compiled = False


def register(
    namespace: dict[str, Any],
    pure: dict[str, Callable[..., Any]],
    public: tuple[str, ...],
    calls: Mapping[str, Callable[..., int]] | None = None,
) -> dict[str, Callable[..., Any]]:
    """Put a module's kernels under the switch; return its public kernels.

    Parameters
    ----------
    namespace : dict
        The module's ``globals()``, whose names :func:`compile_kernels`
        points at the compiled functions.
    pure : dict
        The module's kernels as Python by the names its code calls them
        (``_name`` behind a public ``name``), with the kernels of other
        modules it calls (one compiled function each).
    public : tuple of str
        Names of the kernels callers use: ``name`` runs ``_name``.
    calls : mapping of str to callable, optional
        For a public kernel doing the work of many calls (a loop over rows),
        how many calls one call counts for, given its arguments (default 1).

    Returns
    -------
    dict
        ``name`` -> ``_name`` run as Python for the first :data:`PURE_CALLS`
        kernel calls of the process (all modules counted), then compiled.
    """
    _MODULES.append((namespace, pure, public))
    namespace.update(pure)  # as Python, also those imported from a module already compiled
    if _compiled:  # a module imported after the switch: compiled at once
        _compile_module(namespace, pure, public)
    counts = calls or {}
    return {
        name: _python_first(namespace, pure[f"_{name}"], name, counts.get(name, _one_call))
        for name in public
    }


def _one_call(*args: Any) -> int:
    """Count a kernel call as one call."""
    return 1


def compile_kernels() -> None:
    """Replace every kernel of every registered module by its numba version (disk cache).

    ``error_model="numpy"``: a division by zero gives inf/NaN (caught as a
    non-finite state), no exception.
    """
    global _compiled
    if _compiled:
        return
    _DISPATCHERS.clear()
    for module in _MODULES:
        _compile_module(*module)
    _compiled = True


def _compile_module(
    namespace: dict[str, Any], pure: dict[str, Callable[..., Any]], public: tuple[str, ...]
) -> None:
    """Point a module's kernel names at their numba versions (one per Python function)."""
    from numba import njit  # ~0.5 s and ~60 MiB: only once a run is long enough to pay

    for name, function in pure.items():
        if function not in _DISPATCHERS:
            _DISPATCHERS[function] = njit(cache=True, error_model="numpy")(function)
        namespace[name] = _DISPATCHERS[function]
    for name in public:  # callers looking the kernels up there get no wrapper any more
        namespace[name] = namespace[f"_{name}"]


def _python_first(
    namespace: dict[str, Any],
    function: Callable[..., Any],
    name: str,
    counts: Callable[..., int],
) -> Callable[..., Any]:
    """Return ``function`` run as Python for the first :data:`PURE_CALLS` calls, then compiled.

    A call counts for ``counts(*args)`` calls (see :func:`register`).
    """

    def call(*args: Any) -> Any:
        global _calls
        if not _compiled:
            _calls += counts(*args)
            if _calls <= PURE_CALLS:
                with np.errstate(all="ignore"):  # as numba's error_model="numpy"
                    return function(*args)
            compile_kernels()
        compiled = namespace[f"_{name}"]
        namespace[name] = compiled  # also if the module bound the wrapper after the switch
        return compiled(*args)

    call.__name__, call.__doc__ = name, function.__doc__
    return call
