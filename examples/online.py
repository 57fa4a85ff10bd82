"""Stream the demo log through the streaming API, sample by sample, as a robot would.

Usage::

    python examples/online.py

Per row of ``examples/demo_log.csv``: the terrain label when it changes, the
track speeds, the pose measurement when the row has one; then prints the
final state (the same as ``terrain-odom run --wheels examples/demo_log.csv
--config examples/demo.yaml`` writes in its last ``trajectory.csv`` row).
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

from terrain_odom import OnlineOdometry

HERE = Path(__file__).resolve().parent


def main() -> dict[str, float | str | None]:
    """Stream the demo log; print and return the final state."""
    odo = OnlineOdometry.from_config(HERE / "demo.yaml")
    label = None
    with (HERE / "demo_log.csv").open(newline="") as handle:
        for row in csv.DictReader(handle):
            t = float(row["t"])
            if row["terrain"] != label:
                label = row["terrain"]
                odo.terrain(t, label)
            odo.wheels(t, float(row["v_l"]), float(row["v_r"]))
            pose = [float(row[k]) if row[k] else math.nan for k in ("x", "y", "yaw")]
            if not all(math.isnan(v) for v in pose):
                odo.pose(t, *pose)
    state = odo.state()
    for name, value in state.items():
        print(f"{name:>10}: {value:.4f}" if isinstance(value, float) else f"{name:>10}: {value}")
    return state


if __name__ == "__main__":
    main()
