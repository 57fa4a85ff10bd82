"""How fast can the ICRs re-converge after a terrain change? The data's own bound.

For scenario ``chen2023`` (no frames) at two pose-sensor noise levels, per seed:

- **batch**: nonlinear least squares of ``y_l, y_r, x_icr, alpha`` and the start
  pose on the poses from the true change to ``t_c + T`` (weighted by the true
  noise, knowing the change time), for ``T = 0.5, 0.6, ... 4 s``; its settling
  time is the first ``T`` from which every longer span's estimate is within
  the report's band (``evaluation.icr_tolerance * B``, 5 cm) of the truth. No
  causal filter fed the same poses can be expected to do better.
- **filter**: the ICR EKF (the run's ``config.yaml``) with the terrain labels
  of the ground truth, reset when the robot enters gravel (``on time``) or
  0.2 s later (``late``: what the camera achieves in ``bench/chen2023.py``,
  0.18-0.22 s, as a majority of the region's tiles turns gravel only once
  the edge is past its middle), each with the pose inflation of a change
  (``ekf.sigma_pb_pose``, default) and without it (``no infl.``); its
  re-convergence time as in ``run --groundtruth``.

Prints the settling times per seed and, per column, how many are <= 2 s.

Usage::

    python bench/reconvergence_bound.py [--seeds 0 1 ... 11] [--work /tmp/bound]

About 4 min on one core.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np
from slip_ekf import batch_icrs  # bench/ is on the path when this script runs

from terrain_odom.app.groundtruth import groundtruth_section
from terrain_odom.app.simulate import write_simulation
from terrain_odom.config import PoseSigmas, load_config
from terrain_odom.io import read_wheel_log
from terrain_odom.io.groundtruth import read_groundtruth
from terrain_odom.sim import get_scenario, simulate

NOISE = {"2 cm / 0.57 deg": (0.02, 0.01), "1 cm / 0.20 deg (RTK)": (0.01, 0.0035)}
SPANS = np.round(np.arange(0.5, 4.001, 0.1), 2)
GRASS = (0.42, -0.40, 0.05, 0.93)  # the batch's start (alpha fitted too): the terrain left
LATE = 0.2  # s, the camera's lateness in bench/chen2023.py


def batch_settling(log, gt, noise, tolerance: float) -> float | None:
    """First span from which every longer span's batch estimate is within the band."""
    t_c = gt.changes()[0][0]
    truth = gt.icr[np.searchsorted(gt.t, t_c)]
    scale = (noise[0], noise[0], noise[1])
    inside = np.array(
        [
            np.all(np.abs(batch_icrs(log, t_c, t_c + T, GRASS, scale) - truth) <= tolerance)
            for T in SPANS
        ]
    )
    outside = np.flatnonzero(~inside)
    if outside.size == 0:
        return float(SPANS[0])
    return None if outside[-1] == SPANS.size - 1 else float(SPANS[outside[-1] + 1])


def filter_settling(log, gt, config, late: float = 0.0) -> float | None:
    """Re-convergence of the EKF reset ``late`` s after the true change (first change)."""
    labels = gt.terrain[np.clip(np.searchsorted(gt.t, log.t - late - 1e-9), 0, len(gt) - 1)]
    section = groundtruth_section(log, config, gt, labels=list(labels)).section
    return section.reconvergence["ekf (terrain + memory)"][0].settling_s


def _fmt(values) -> str:
    within = sum(v is not None and v <= 2.0 for v in values)
    return ", ".join("never" if v is None else f"{v:.1f}" for v in values) + f" ({within} <= 2 s)"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=list(range(12)))
    parser.add_argument("--work", type=Path, default=Path("/tmp/bound"))
    args = parser.parse_args()
    print(f"first change (grass -> gravel) of chen2023, seeds {args.seeds}, settling s")
    for name, (xy, yaw) in NOISE.items():
        scenario = dataclasses.replace(get_scenario("chen2023"), sigma_xy=xy, sigma_yaw=yaw)
        columns: dict[str, list] = {}
        for seed in args.seeds:
            out = args.work / f"{xy}-{yaw}" / f"seed{seed}"
            write_simulation(simulate(scenario, seed), out, frames=False, patches=False)
            log, gt = read_wheel_log(out / "log.csv"), read_groundtruth(out / "groundtruth.csv")
            config = load_config(out / "config.yaml")
            tight = dataclasses.replace(config.ekf, sigma_pb_pose=PoseSigmas(1e-6, 1e-6, 1e-6))
            no_inflation = dataclasses.replace(config, ekf=tight)
            tolerance = config.evaluation.icr_tolerance * config.robot.track_width
            settled = {
                "batch": batch_settling(log, gt, (xy, yaw), tolerance),
                "on time": filter_settling(log, gt, config),
                "on time, no infl.": filter_settling(log, gt, no_inflation),
                "late": filter_settling(log, gt, config, LATE),
                "late, no infl.": filter_settling(log, gt, no_inflation, LATE),
            }
            for column, value in settled.items():
                columns.setdefault(column, []).append(value)
        print(f"pose noise {name}")
        for column, values in columns.items():
            print(f"   {column:<18} {_fmt(values)}")


if __name__ == "__main__":
    main()
