"""Validation of configuration dataclasses from YAML mappings.

Any module can define its own frozen dataclass section and validate it with
:func:`build_section` (this module imports nothing else of the package but
its errors, so there is no import cycle). A float field must be > 0 unless
its metadata says otherwise::

    offset: float = field(default=0.0, metadata=SIGNED)
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import types
import typing
from collections.abc import Mapping
from typing import Any

from terrain_odom.errors import ConfigError

__all__ = ["SIGNED", "NON_NEGATIVE", "build_section"]

SIGNED = {"range": "signed"}
"""Any finite value."""

NON_NEGATIVE = {"range": "non-negative"}
"""Finite and >= 0."""


_NON_NEGATIVE_PARENTS = {"sigma_q"}  # process noise densities may be 0


def _check_float(value: Any, where: str, allowed: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(f"{where}: must be a number, got {value!r}")
    try:
        value = float(value)
    except OverflowError:  # an integer beyond the float range
        value = math.inf
    if not math.isfinite(value):
        raise ConfigError(f"{where}: must be finite, got {value!r}")
    if allowed == "non-negative" and value < 0.0:
        raise ConfigError(f"{where}: must be >= 0, got {value!r}")
    if allowed == "positive" and value <= 0.0:
        raise ConfigError(f"{where}: must be > 0, got {value!r}")
    return value


def _check_value(hint: Any, raw: Any, key: str, allowed: str) -> Any:
    """Validate one scalar or tuple field against its type hint."""
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if hint is bool:
        if not isinstance(raw, bool):
            raise ConfigError(f"{key}: must be true or false, got {raw!r}")
        return raw
    if hint is int:
        if isinstance(raw, bool) or not isinstance(raw, int) or raw < 1:
            raise ConfigError(f"{key}: must be a whole number >= 1, got {raw!r}")
        return raw
    if hint is float:
        return _check_float(raw, key, allowed)
    if hint is str:
        if not isinstance(raw, str) or not raw:
            raise ConfigError(f"{key}: must be a non-empty string, got {raw!r}")
        return raw
    if origin is typing.Literal:
        if raw not in args:
            raise ConfigError(f"{key}: must be one of {list(args)}, got {raw!r}")
        return raw
    if origin in (typing.Union, types.UnionType) and type(None) in args:
        if raw is None:
            return None
        inner = [a for a in args if a is not type(None)]
        if len(inner) == 1:
            return _check_value(inner[0], raw, key, allowed)
        args = tuple(inner)  # e.g. float | Literal["auto"] | None: one of the others
    if origin in (typing.Union, types.UnionType):  # e.g. float | Literal["auto"]
        for option in args:
            with contextlib.suppress(ConfigError):
                return _check_value(option, raw, key, allowed)
        raise ConfigError(f"{key}: must be {' or '.join(map(_describe, args))}, got {raw!r}")
    if origin is tuple and args[-1] is Ellipsis:
        if not isinstance(raw, (list, tuple)):
            raise ConfigError(f"{key}: must be a list of numbers, got {raw!r}")
        return tuple(_check_value(args[0], v, f"{key}[{i}]", allowed) for i, v in enumerate(raw))
    raise TypeError(f"config field {key} has an unsupported type {hint!r}")  # a bug, not input


def _describe(hint: Any) -> str:
    """How a value of one alternative of a union field is described in messages."""
    if typing.get_origin(hint) is typing.Literal:
        return " or ".join(repr(a) for a in typing.get_args(hint))
    return {float: "a finite number", int: "a whole number >= 1", bool: "true or false"}.get(
        hint, str(hint)
    )


def _build(default: Any, data: Any, where: str) -> Any:
    """Return dataclass instance ``default`` updated from a mapping.

    Keys left out keep the values of ``default``; unknown keys are rejected.
    Floats must be > 0 unless their field's metadata is :data:`SIGNED` or
    :data:`NON_NEGATIVE` (process noise densities may be 0).
    """
    cls = type(default)
    if not isinstance(data, Mapping):
        raise ConfigError(
            f"{where or 'top level'}: expected a mapping of keys, got {type(data).__name__}"
        )
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(str(k) for k in set(data) - set(fields))
    if unknown:
        raise ConfigError(
            f"{where or 'top level'}: unknown key(s) {unknown}; allowed: {sorted(fields)}"
        )
    values = {}
    parent = where.rsplit(".", 1)[-1]
    prefix = f"{where}." if where else ""
    # Per-terrain overrides last: their missing keys come from the final sigma_pb.
    for name, raw in sorted(data.items(), key=lambda item: item[0] == "sigma_pb_per_terrain"):
        key = f"{prefix}{name}"
        hint = hints[name]
        if dataclasses.is_dataclass(hint):
            values[name] = _build(getattr(default, name), raw, key)
        elif typing.get_origin(hint) is dict:  # dict[str, IcrSigmas]: missing keys from sigma_pb
            if not isinstance(raw, Mapping):
                raise ConfigError(f"{key}: expected a mapping of terrain label to sigmas")
            base = values.get("sigma_pb", default.sigma_pb)
            values[name] = {str(k): _build(base, v, f"{key}.{k}") for k, v in raw.items()}
        else:
            allowed = fields[name].metadata.get("range", "positive")
            if parent in _NON_NEGATIVE_PARENTS:
                allowed = "non-negative"
            values[name] = _check_value(hint, raw, key, allowed)
    try:
        return dataclasses.replace(default, **values)
    except ConfigError as exc:  # a section's own consistency check (__post_init__)
        raise ConfigError(f"{where}.{exc}" if where else str(exc)) from None


def build_section(default: Any, data: Any, where: str = "") -> Any:
    """Validate a mapping into a copy of the dataclass instance ``default``.

    Keys left out keep the values of ``default``; unknown keys are rejected;
    floats must be > 0 unless marked :data:`SIGNED` / :data:`NON_NEGATIVE`;
    ``Literal`` fields take one of their choices; ``tuple[float, ...] | None``
    fields take a list of numbers or null; nested dataclasses recurse.

    Raises
    ------
    ConfigError
        Naming the key (prefixed by ``where``).
    """
    return _build(default, data, where)
