"""Load a YAML configuration into :class:`~terrain_odom.config.sections.Config`, validated."""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, Literal

import yaml

from terrain_odom.config.classifier import ClassifierConfig, is_flat_classifier
from terrain_odom.config.fields import build_section
from terrain_odom.config.sections import (
    FORMAT_VERSION,
    MAX_ANTENNA_OFFSET,
    MAX_POSE_DELAY,
    Config,
    PoseSensorConfig,
    TimeConfig,
)
from terrain_odom.errors import ConfigError, TerrainOdomError

__all__ = [
    "load_config",
    "validate_config",
    "load_classifier_config",
    "read_yaml",
    "config_to_dict",
    "dump_config",
    "with_pose_delay",
]


def _check_pose_delay(delay: float | Literal["auto"], where: str) -> None:
    if delay != "auto" and not abs(delay) <= MAX_POSE_DELAY:
        raise ConfigError(
            f"{where}: {delay:g} s is not a stamp delay (|d| <= {MAX_POSE_DELAY:g} s); "
            "give seconds, or auto"
        )


def with_pose_delay(config: Config, text: str | None, where: str = "--pose-delay") -> Config:
    """Return ``config`` with ``time.pose_delay`` from a command-line value.

    Parameters
    ----------
    config : Config
        The configuration loaded.
    text : str or None
        ``"auto"`` or a number of seconds; None keeps ``config``'s value.
    where : str
        Name of the option, for messages.

    Raises
    ------
    ConfigError
        If ``text`` is neither ``auto`` nor a number of seconds within
        :data:`MAX_POSE_DELAY`.
    """
    if text is None:
        return config
    value: float | Literal["auto"]
    if text.strip() == "auto":
        value = "auto"
    else:
        try:
            value = float(text)
        except ValueError:
            raise ConfigError(f"{where}: must be auto or seconds, got {text!r}") from None
        if not math.isfinite(value):
            raise ConfigError(f"{where}: must be auto or finite seconds, got {text!r}")
    _check_pose_delay(value, where)
    return dataclasses.replace(config, time=TimeConfig(pose_delay=value))


def _check_pose_sensor(sensor: PoseSensorConfig) -> None:
    for name in ("antenna_x", "antenna_y"):
        value = getattr(sensor, name)
        if value != "auto" and not abs(value) <= MAX_ANTENNA_OFFSET:
            raise ConfigError(
                f"pose_sensor.{name}: {value:g} m is not an antenna offset on a robot "
                f"(|offset| <= {MAX_ANTENNA_OFFSET:g} m); give metres"
            )
    offset = sensor.heading_offset
    if offset != "auto" and not abs(offset) <= math.pi:
        raise ConfigError(
            f"pose_sensor.heading_offset: {offset:g} is not an angle in radians "
            "(|offset| <= pi); degrees? give radians, or auto"
        )


def _check_consistency(config: Config) -> None:
    ini, lim = config.ekf.initial.resolve(config.robot), config.ekf.limits.resolve(config.robot)
    if not ini.y_l > 0.0 > ini.y_r:
        raise ConfigError(
            f"ekf.initial needs y_l > 0 > y_r (left ICR left of the body), "
            f"got y_l={ini.y_l}, y_r={ini.y_r}"
        )
    if not lim.half_width_min < lim.half_width_max:
        raise ConfigError(
            f"ekf.limits: half_width_min ({lim.half_width_min:g} m) must be < half_width_max "
            f"({lim.half_width_max:g} m; null: from robot.track_width)"
        )
    if not lim.alpha_min <= ini.alpha <= lim.alpha_max:
        raise ConfigError("ekf.initial.alpha must lie in [alpha_min, alpha_max]")
    for name, value, low, high in (
        ("y_l", ini.y_l, lim.half_width_min, lim.half_width_max),
        ("y_r", -ini.y_r, lim.half_width_min, lim.half_width_max),
        ("x_icr", abs(ini.x_icr), 0.0, lim.x_icr_max),
    ):
        if not low <= value <= high:
            raise ConfigError(
                f"ekf.initial.{name}: {getattr(ini, name):g} m is beyond ekf.limits "
                f"(|{name}| in [{low:g}, {high:g}] m, from robot.track_width and robot.length "
                "unless set)"
            )
    slip = config.slip_ekf
    if not (slip.lateral_acceleration or slip.curvature):
        raise ConfigError(
            "slip_ekf: lateral_acceleration and curvature are both false; "
            "the ICRs need at least one feature"
        )
    if not slip.limits.half_width_min < slip.limits.half_width_max:
        raise ConfigError("slip_ekf.limits.half_width_min must be < half_width_max")
    if not slip.limits.alpha_min <= slip.initial.alpha <= slip.limits.alpha_max:
        raise ConfigError("slip_ekf.initial.alpha must lie in [limits.alpha_min, alpha_max]")
    for name in ("pose_delay", "position_delay", "heading_delay"):
        delay = getattr(config.time, name)
        if delay is not None:
            _check_pose_delay(delay, f"time.{name}")
    _check_pose_sensor(config.pose_sensor)
    if config.format_version != FORMAT_VERSION:
        raise ConfigError(
            f"format_version {config.format_version} is not supported "
            f"(this version of terrain-odom reads {FORMAT_VERSION})"
        )


class _Loader(yaml.SafeLoader):
    """PyYAML's safe loader reading every float spelling a user writes.

    YAML 1.1 (PyYAML) reads ``1.0e9`` (no exponent sign) and ``1e-300`` (no
    dot) as strings; YAML 1.2 and every user read them as numbers.
    """


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$"),
    list("-+0123456789."),
)


def read_yaml(
    path: Path, *, kind: str = "config file", error: type[TerrainOdomError] = ConfigError
) -> Any:
    """Read a YAML file into plain data (``None`` if it is empty).

    Parameters
    ----------
    path : Path
        The file.
    kind : str
        What the file is, for messages (e.g. ``"parameter file"``).
    error : type of TerrainOdomError
        The exception raised on a problem.

    Raises
    ------
    ConfigError
        (or ``error``) The file is missing, unreadable, not UTF-8 text or not
        valid YAML, naming the file and, where known, the line.
    """
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise error(f"{path}: {kind} not found") from None
    except UnicodeDecodeError as exc:
        raise error(
            f"{path}: not a UTF-8 text file (byte {exc.start}: {exc.reason}); is it a YAML {kind}?"
        ) from None
    except OSError as exc:
        raise error(f"{path}: cannot read {kind} ({exc.strerror or exc})") from None
    try:
        return yaml.load(text, Loader=_Loader)  # noqa: S506 - a SafeLoader
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = f", line {mark.line + 1}" if mark is not None else ""
        raise error(f"{path}{line}: not valid YAML") from None
    except RecursionError:
        raise error(f"{path}: not a YAML {kind} (nested too deeply)") from None
    except (ValueError, OverflowError) as exc:  # e.g. a date like 2024-13-45
        raise error(f"{path}: not valid YAML ({exc})") from None


def load_config(path: str | Path | None = None) -> Config:
    """Load and validate a YAML configuration.

    Parameters
    ----------
    path : str or Path, optional
        YAML file. Keys left out take the defaults of :class:`Config` (which
        are those of ``config/default.yaml``); ``None`` returns the defaults.

    Returns
    -------
    Config

    Raises
    ------
    ConfigError
        Naming the file and the key of the first invalid or unknown entry.
    """
    if path is None:
        return Config()
    path = Path(path)
    return _validated(read_yaml(path), path)


def validate_config(data: Any, where: str) -> Config:
    """Return the configuration of YAML data (e.g. before writing it), validated.

    Raises
    ------
    ConfigError
        Naming ``where`` and the key of the first invalid or unknown entry.
    """
    return _validated(data, Path(where))


def _validated(data: Any, path: Path) -> Config:
    """Return the configuration of a file's YAML data, validated; errors name ``path``."""
    try:
        config = build_section(Config(), data or {}, "")
        _check_consistency(config)
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None
    return config


def load_classifier_config(
    path: str | Path | None = None,
    overrides: Mapping[str, Any] | None = None,
    *,
    on_flat: Callable[[Path], None] | None = None,
) -> ClassifierConfig:
    """Load the classifier settings of a configuration: its ``classifier`` section.

    A configuration file (the layout of ``config/default.yaml``, validated
    whole) holds them as, e.g. Chen et al.'s recipe::

        classifier:
          features: sfta
          relative_counts: false
          scale: false
          k: 5
          weights: uniform
          tiles: 1

    A flat classifier file, those keys at the top level (the old layout,
    deprecated), is read too.

    Parameters
    ----------
    path : str or Path, optional
        YAML file; keys left out keep the defaults. ``None``: the defaults.
    overrides : mapping, optional
        Values that replace those of the file (e.g. command-line options),
        validated by the same rules.
    on_flat : callable, optional
        Called with ``path`` when the file is a flat classifier file (e.g. to
        say that the layout is deprecated).

    Raises
    ------
    ConfigError
        Naming the file and the first unknown or invalid key.
    """
    config = ClassifierConfig()
    if path is not None:
        path = Path(path)
        data = read_yaml(path)
        if not is_flat_classifier(data):
            config = _validated(data, path).classifier
        else:
            if on_flat is not None:
                on_flat(path)
            try:
                config = build_section(config, data)
            except ConfigError as exc:
                raise ConfigError(f"{path}: {exc}") from None
    result: ClassifierConfig = build_section(config, dict(overrides or {}))
    return result


def config_to_dict(config: Config) -> dict[str, Any]:
    """Return the configuration as plain data (for reports and YAML)."""
    return dataclasses.asdict(config)


def dump_config(config: Config, comments: Mapping[str, str] | None = None) -> str:
    """Return the configuration as YAML text that :func:`load_config` reads back equal.

    ``comments`` maps dotted keys (``pose_sensor.antenna_x``) to a comment
    written at the end of that key's line.

    Examples
    --------
    >>> text = dump_config(Config(), {"robot.track_width": "measured"})
    >>> [line for line in text.splitlines() if "track_width" in line]
    ['  track_width: 0.5  # measured']
    """
    text = yaml.safe_dump(_plain(config_to_dict(config)), sort_keys=False)
    if not comments:
        return text
    lines, path = text.splitlines(), list[str]()
    for i, line in enumerate(lines):
        depth = (len(line) - len(line.lstrip(" "))) // 2
        key = line.strip().split(":", 1)[0]
        path = [*path[:depth], key]
        note = comments.get(".".join(path))
        if note is not None:
            lines[i] = f"{line}  # {note}"
    return "\n".join(lines) + "\n"


def _plain(value: Any) -> Any:
    """Tuples to lists, recursively (YAML's safe dumper writes no tuples)."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value
