"""Whether a path names a ROS bag, by its name only (no ``rosbags`` import).

Commands that take a wheel log or a bag ask this first; only a bag then
loads :mod:`terrain_odom.io.bag.reader` and ``rosbags`` (~50 ms of start-up
that a run on a CSV log does not pay).
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["is_bag"]


def is_bag(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` looks like a bag: a ``.bag``/``.mcap``/``.db3`` file or a ROS 2 folder.

    By name only (a ROS 2 folder holds ``metadata.yaml``);
    :func:`~terrain_odom.io.bag.reader.open_bag` says whether it is readable.
    """
    p = Path(path)
    if p.is_dir():
        return (p / "metadata.yaml").is_file()
    return p.suffix in (".bag", ".mcap", ".db3")
