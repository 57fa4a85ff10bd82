"""What the plausibility checks measure on the real logs, and how long they take.

For every wheel log of ``../shared/data/drive`` (read with
``config/warthog.yaml``'s wheel radius) and the shipped logs, prints the
ratio of pose to wheel travel, the fitted ratio of measured to ideal turn,
their correlation, the findings (none expected) and the time of
:func:`terrain_odom.evaluation.check_log` (best of 5), against reading the
same log. The figures are those of docs/cli.md, "Plausibility checks".

Usage::

    python bench/plausibility.py
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

from terrain_odom.config import load_config
from terrain_odom.evaluation import check_log
from terrain_odom.io import read_wheel_log

REPO = Path(__file__).resolve().parents[1]
DRIVE = REPO.parent / "shared" / "data" / "drive"


def _best(fn: Callable[[], object], repeat: int = 5) -> float:
    times = []
    for _ in range(repeat):
        started = time.perf_counter()
        fn()
        times.append(time.perf_counter() - started)
    return min(times)


def main() -> None:
    """Print one line per log."""
    warthog = load_config(REPO / "config" / "warthog.yaml").robot
    logs = [(p, warthog) for p in sorted(DRIVE.glob("*.csv"))]
    logs += [
        (REPO / "examples" / "demo_log.csv", load_config(REPO / "examples" / "demo.yaml").robot)
    ]
    sample = REPO / "sample_images" / "chen2023"
    logs += [(sample / "log.csv", load_config(sample / "config.yaml").robot)]
    print(
        f"{'log':<44} {'travel':>7} {'turn':>6} {'corr':>6} {'check ms':>9} {'read ms':>8}  findings"
    )
    for path, robot in logs:
        log = read_wheel_log(path, wheel_radius=robot.wheel_radius)
        result = check_log(log, robot.track_width)
        check = _best(lambda: check_log(log, robot.track_width))  # noqa: B023
        read = _best(lambda: read_wheel_log(path, wheel_radius=robot.wheel_radius), 2)  # noqa: B023
        travel = result.pose_travel / result.wheel_travel
        print(
            f"{path.name[:44]:<44} {travel:7.2f} {result.yaw_scale:6.2f} "
            f"{result.yaw_correlation:6.2f} {1e3 * check:9.1f} {1e3 * read:8.1f}  "
            f"{[f.check for f in result.findings] or 'none'}"
        )


if __name__ == "__main__":
    main()
