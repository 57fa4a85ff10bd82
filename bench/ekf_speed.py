"""Speed of the ICR EKF over a wheel log, against baselines measured in the same run.

Prints the time per wheel sample of ``run_icr_ekf`` (predict at every row,
update at every pose) and, as ratios, against (a) reading the same log from
CSV and (b) dead-reckoning it with the vectorised exact integration.

Usage::

    python bench/ekf_speed.py [LOG.csv] [--config config/warthog.yaml] [--repeat 3]

Without a log it uses examples/demo_log.csv with examples/demo.yaml.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from terrain_odom.config import load_config
from terrain_odom.estimation.odometry import run_icr_ekf
from terrain_odom.evaluation import dead_reckon
from terrain_odom.io import read_wheel_log
from terrain_odom.kinematics import twist_idd

REPO = Path(__file__).resolve().parents[1]


def best_of(repeat, fn):
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("log", nargs="?", default=str(REPO / "examples" / "demo_log.csv"))
    parser.add_argument("--config", default=None)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    config = args.config or (
        str(REPO / "examples" / "demo.yaml") if args.log.endswith("demo_log.csv") else None
    )
    cfg = load_config(config)
    log = read_wheel_log(args.log, wheel_radius=cfg.robot.wheel_radius)
    n = len(log)
    t_read = best_of(
        args.repeat, lambda: read_wheel_log(args.log, wheel_radius=cfg.robot.wheel_radius)
    )
    t_dr = best_of(
        args.repeat, lambda: dead_reckon(log, *twist_idd(log.v_l, log.v_r, cfg.robot.track_width))
    )
    t_ekf = best_of(args.repeat, lambda: run_icr_ekf(log, cfg, labels=log.terrain))
    span = float(log.t[-1] - log.t[0])
    print(
        f"log: {args.log} ({n} rows, {int(np.isfinite(log.pose).any(axis=1).sum())} poses, {span:.0f} s)"
    )
    print(f"  read CSV            {1e6 * t_read / n:8.2f} us/row")
    print(f"  dead-reckon (numpy) {1e6 * t_dr / n:8.2f} us/row")
    print(
        f"  ICR EKF             {1e6 * t_ekf / n:8.2f} us/row  = {t_ekf / t_read:.1f}x reading, "
        f"{t_ekf / t_dr:.0f}x dead-reckoning; {span / t_ekf:.0f}x real time; "
        f"max wheel rate {n / t_ekf:.0f} Hz on one core"
    )


if __name__ == "__main__":
    main()
