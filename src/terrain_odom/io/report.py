"""Atomic JSON output for reports."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from terrain_odom.io.atomic import write_text_atomic

__all__ = ["REPORT_FORMAT_VERSION", "report_header", "path_or_none", "write_json", "to_jsonable"]

REPORT_FORMAT_VERSION = 1
"""Version of the JSON reports (``report.json``, ``evaluation.json``, ``compare.json`` ...)."""


def report_header(command: str) -> dict[str, Any]:
    """Return the fields every JSON report starts with.

    Parameters
    ----------
    command : str
        The subcommand that wrote the report (``run``, ``evaluate`` ...).

    Examples
    --------
    >>> sorted(report_header("run"))
    ['command', 'format_version', 'terrain_odom_version']
    """
    from terrain_odom import __version__

    return {
        "format_version": REPORT_FORMAT_VERSION,
        "terrain_odom_version": __version__,
        "command": command,
    }


def path_or_none(path: str | Path | None) -> str | None:
    """Return ``path`` made absolute for a report, or ``None`` when no file was given."""
    return None if path is None else str(Path(path).resolve())


def to_jsonable(value: Any) -> Any:
    """Convert numpy scalars/arrays and non-finite floats to plain JSON data.

    NaN and infinities become ``None`` (JSON has no such numbers).
    """
    if isinstance(value, dict):
        return {str(k): to_jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return to_jsonable(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def write_json(path: str | Path, data: Any) -> None:
    """Write ``data`` as indented JSON atomically (see :func:`~terrain_odom.io.atomic.write_atomic`).

    A reader never sees a half-written file, and an existing file is only
    replaced once the new one is complete.
    """
    text = json.dumps(to_jsonable(data), indent=2, allow_nan=False) + "\n"
    write_text_atomic(path, text)
