"""Tests of :mod:`terrain_odom.estimation._kernel_switch`: kernels registered with the switch."""

from __future__ import annotations

from terrain_odom.estimation import _kernel_switch


def _twice(value: float) -> float:
    """Return ``2 value`` (a kernel registered late)."""
    return 2.0 * value


def test_a_module_registered_after_the_switch_is_compiled_at_once(monkeypatch):
    """A kernel module imported after the switch runs compiled, without the Python wrapper."""
    _kernel_switch.compile_kernels()
    monkeypatch.setattr(_kernel_switch, "_MODULES", list(_kernel_switch._MODULES))
    namespace = {"_twice": _twice}
    wrappers = _kernel_switch.register(namespace, {"_twice": _twice}, ("twice",))
    assert namespace["_twice"].py_func is _twice  # a numba dispatcher
    namespace["twice"] = wrappers["twice"]  # as a module binds its public names
    assert wrappers["twice"](1.5) == 3.0
    assert namespace["twice"] is namespace["_twice"]  # the wrapper took itself out
