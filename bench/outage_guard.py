"""Cost of the run's outage guard against the whole run (issue 23: <= 10 % of a run).

Makes a GPS + IMU wheel log of ``--minutes`` at ``--rate`` Hz (a skid-steer
robot, ICRs 1.5x the nominal track, driving smooth random curves; GPS fixes
of its antenna at 2.5 Hz with 0.8 m noise and IMU headings at 50 Hz, each on
wheel rows of its own: no row holds both), runs ``terrain-odom run`` on it
through the Python API (no plots, no frames) and prints the run's wall time,
the guard's (keeping the states at the outage starts while streaming, then
dead-reckoning learned, nominal and idd through every 30-s and 60-s outage
window: ``RunSummary.outage_guard.seconds``), and their ratio, measured in
the same run; the best of ``--repeat`` runs by the ratio, and the machine's
load before and after. The target is a ratio <= 0.10.

Usage::

    python bench/outage_guard.py [--minutes 60] [--rate 100] [--repeat 2] [--work /tmp/bench_guard]
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

import numpy as np

from terrain_odom.app.inputs import TerrainSource
from terrain_odom.app.run import RunOptions, run
from terrain_odom.io.wheel_log import write_wheel_log
from terrain_odom.kinematics import integrate, twist_icr
from terrain_odom.records import WheelLog

CONFIG = """\
robot:
  wheel_radius: 0.3
  track_width: 1.0
pose_sensor:
  antenna_x: -0.5
ekf:
  sigma_r: {x: 0.8, y: 0.8, yaw: 0.05}
"""


def _speeds(n: int, dt: float, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Smooth random track speeds, m/s: a forward speed and a turn rate changing every ~5 s."""
    knots = np.arange(0, n + 500, 500)
    forward = np.interp(np.arange(n), knots, rng.uniform(0.2, 1.5, knots.size))
    turn = np.interp(np.arange(n), knots, rng.uniform(-0.6, 0.6, knots.size))
    return forward - turn, forward + turn


def make_log(minutes: float, rate: float, seed: int = 0) -> WheelLog:
    """Make a GPS + IMU log (positions and headings on their own rows, wheel rows between)."""
    rng = np.random.default_rng(seed)
    dt = 1.0 / rate
    n = int(minutes * 60.0 * rate)
    t = np.arange(n) * dt
    v_l, v_r = _speeds(n, dt, rng)
    true = integrate(*twist_icr(v_l[:-1], v_r[:-1], 0.75, -0.75, 0.05, 0.95), np.diff(t))
    pose = np.full((n, 3), np.nan)
    gps = np.arange(0, n, int(rate / 2.5))
    c, s = np.cos(true[gps, 2]), np.sin(true[gps, 2])
    pose[gps, 0] = true[gps, 0] - 0.5 * c + rng.normal(0.0, 0.8, gps.size)
    pose[gps, 1] = true[gps, 1] - 0.5 * s + rng.normal(0.0, 0.8, gps.size)
    imu = np.setdiff1d(np.arange(1, n, int(rate / 50.0)), gps)
    pose[imu, 2] = true[imu, 2] + rng.normal(0.0, 0.02, imu.size)
    return WheelLog(t, v_l, v_r, pose, None, np.zeros(n, dtype=int), "bench")


def main() -> None:
    """Time the guard against the run; print the ratio."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--minutes", type=float, default=60.0)
    parser.add_argument("--rate", type=float, default=100.0)
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--work", default="/tmp/bench_guard")
    args = parser.parse_args()
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    log_path, config = work / "log.csv", work / "config.yaml"
    config.write_text(CONFIG)
    write_wheel_log(log_path, make_log(args.minutes, args.rate))
    print(f"load before: {os.getloadavg()[0]:.2f}")
    best = None
    for k in range(args.repeat):
        summary = run(
            log_path,
            work / f"run{k}",
            RunOptions(
                config_path=config,
                terrain=TerrainSource.NONE,
                progress=False,
                plots=False,
                overwrite=True,
            ),
        )
        guard = json.loads(summary.report_json.read_text())["outage_guard"]
        assert summary.outage_guard is not None
        seconds = summary.outage_guard.seconds
        ratio = seconds / summary.report.run_time_s
        windows = {d: e["windows"] for d, e in guard.get("durations", {}).items()}
        print(
            f"run {k}: {summary.report.counts.rows} rows in {summary.report.run_time_s:.2f} s, guard {seconds:.3f} s "
            f"(windows {windows}): ratio {ratio:.3f}"
        )
        best = ratio if best is None else min(best, ratio)
    print(f"load after: {os.getloadavg()[0]:.2f}")
    print(f"guard / run, best of {args.repeat}: {best:.3f} (target <= 0.10)")


if __name__ == "__main__":
    main()
