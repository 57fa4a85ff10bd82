"""Acceptance figures of the slip-parameter EKF (README "The slip-parameter EKF").

1. Sec. 4.1 simulation: settling time of the ICRs after the abrupt changes.
2. Sec. 4.2 simulation, pose 1 Hz / wheels 10 Hz: 2-s prediction errors of the
   slip EKF, the ICR EKF fed the same data, and ideal differential drive.
3. Real Warthog logs (../shared/data/drive), pose subsampled to 1 Hz (first
   pose of every whole second) for the filters; the 2-s windows start at those
   poses and end at the full-rate pose nearest 2 s later. Full pose and
   heading only.

Usage::

    PYTHONPATH=src python bench/slip_ekf.py [--data ../shared/data/drive]
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np

from terrain_odom.config import Config, EkfConfig, IcrState, RobotConfig, load_config
from terrain_odom.estimation.odometry import run_icr_ekf
from terrain_odom.estimation.slip_ekf import SlipModel, run_slip_ekf
from terrain_odom.evaluation import icr_twist_from_rows, model_twist, settling_time
from terrain_odom.evaluation.prediction import (
    prediction_errors,
    prediction_windows,
    slip_twist_from_rows,
)
from terrain_odom.io import read_wheel_log
from terrain_odom.kinematics import get_model
from terrain_odom.sim.slip_scenario import TRACK_WIDTH, feature_slip_scenario, icr_switch_scenario

REPO = Path(__file__).resolve().parents[1]


def sim_settling(seeds=range(5)):
    """Print settling times (|ICR error| <= 0.2 m and 0.1 m for good) of Sec. 4.1."""
    import sys

    sys.path.insert(0, str(REPO / "tests" / "estimation"))
    from test_slip_ekf import _sim_config  # the tuning the tests use

    print("1. Sec. 4.1 abrupt ICR change (10 Hz pose, 2 cm / 0.5 deg noise)")
    print("   settling time (s) to |ICR error| <= 0.2 m | 0.1 m, per seed: change at 2 s, at 12 s")
    for adapt in (True, False):
        rows = []
        for seed in seeds:
            sc = icr_switch_scenario(seed=seed)
            res = run_slip_ekf(sc.log, _sim_config(adapt), labels=sc.log.terrain)
            t, icr = sc.log.t, res.states[:, 3:6]
            for t_c in sc.changes:
                piece = (t >= t_c) & (t < t_c + 10.0)
                fin = sc.icr[piece][-1]
                rows.append(
                    [
                        settling_time(t[piece], icr[piece], fin, [tol] * 3, t_from=t_c)
                        for tol in (0.2, 0.1)
                    ]  # fmt: skip
                )
        rows = np.array(rows).reshape(len(seeds), 2, 2)
        for k, t_c in enumerate((2.0, 12.0)):
            print(f"   P reset {'on ' if adapt else 'off'} change at {t_c:4.1f} s:"
                  f" 0.2 m {np.round(rows[:, k, 0], 1).tolist()}"
                  f"  0.1 m {np.round(rows[:, k, 1], 1).tolist()}")  # fmt: skip


def errors(log, windows, twist):
    e = prediction_errors(log, windows, twist)
    return e.position, e.heading


def slip_errors(log, filt_log, windows, cfg, labels=None):
    res = run_slip_ekf(filt_log, cfg, labels=labels)
    model = SlipModel.from_config(cfg.slip_ekf, cfg.robot.track_width)
    n = 6 + cfg.slip_ekf.estimate_alpha
    return errors(log, windows, slip_twist_from_rows(windows, res.states[:, 6 : 6 + n], model))


def icr_errors(log, filt_log, windows, cfg, labels=None):
    res = run_icr_ekf(filt_log, cfg, labels=labels)
    c = dict(zip(res.names, res.states.T, strict=True))
    icr = (c["y_l"], c["y_r"], c["x_icr"], c.get("alpha", 1.0))
    return errors(log, windows, icr_twist_from_rows(windows, *icr))


def sim_one_hz():
    print("\n2. Sec. 4.2: pose 1 Hz, wheels 10 Hz, 120 s, true l = (1, .5, 1.2, .3, .4, .2)")
    print("   mean 2-s prediction error: position (m), heading (deg)")
    cfg = Config(
        robot=RobotConfig(track_width=TRACK_WIDTH),
        ekf=EkfConfig(estimate_alpha=False, initial=IcrState(y_l=1.23, y_r=-1.23)),
    )
    cfg = dataclasses.replace(cfg, slip_ekf=dataclasses.replace(cfg.slip_ekf, estimate_alpha=False))
    table = {"slip-ekf": [], "icr-ekf": [], "idd": []}
    for seed in range(5):
        log = feature_slip_scenario([1.0, 0.5, 1.2, 0.3, 0.4, 0.2], seed=seed).log
        w = prediction_windows(log)
        table["slip-ekf"].append(slip_errors(log, log, w, cfg))
        table["icr-ekf"].append(icr_errors(log, log, w, cfg))
        table["idd"].append(errors(log, w, model_twist(get_model("idd"), [], TRACK_WIDTH)))
    for name, rows in table.items():
        p, h = np.mean(rows, axis=0)
        print(f"   {name:<10} {p:7.3f} m  {np.degrees(h):6.2f} deg  (mean of 5 seeds)")


def one_hz(log):
    """Keep the first pose of every whole second; return the log and those rows."""
    rows = np.flatnonzero(log.has_pose)
    sec = np.floor(log.t[rows])
    keep = rows[np.r_[True, sec[1:] != sec[:-1]]]
    pose = np.full_like(log.pose, np.nan)
    pose[keep] = log.pose[keep]
    return dataclasses.replace(log, pose=pose), keep


def real(data: Path):
    cfg = load_config(REPO / "config" / "warthog.yaml")
    b = cfg.robot.track_width
    print(f"\n3. Real Warthog logs, pose 1 Hz, config/warthog.yaml (B = {b} m), 2-s errors")
    print(f"   {'log':<34} {'n':>4}  {'idd m':>6} {'deg':>5} | {'slip m':>6} {'deg':>5}"
          f" {'-%pos':>5} {'-%hdg':>5} | {'heading-only m':>14} {'deg':>5} {'-%pos':>5}"
          f" {'-%hdg':>5} | {'icr-ekf m':>9} {'deg':>5}")  # fmt: skip
    pooled = {k: [] for k in ("n", "idd", "slip", "ho", "icr")}
    for path in sorted(data.glob("warthog_wheels_*.csv")):
        log = read_wheel_log(path, wheel_radius=cfg.robot.wheel_radius)
        sub, keep = one_hz(log)
        heading = dataclasses.replace(
            sub, pose=np.c_[np.full((len(log), 2), np.nan), sub.pose[:, 2]]
        )
        w = prediction_windows(log, starts=keep)
        idd = errors(log, w, model_twist(get_model("idd"), [], b))
        slip = slip_errors(log, sub, w, cfg, log.terrain)
        ho = slip_errors(log, heading, w, cfg, log.terrain)
        icr = icr_errors(log, sub, w, cfg, log.terrain)
        for k, v in (("n", len(w)), ("idd", idd), ("slip", slip), ("ho", ho), ("icr", icr)):
            pooled[k].append(v)
        line(path.stem.replace("warthog_wheels_", ""), len(w), idd, slip, ho, icr)
    n = np.array(pooled["n"])
    mean = {
        k: np.average(np.array(pooled[k]), axis=0, weights=n) for k in ("idd", "slip", "ho", "icr")
    }
    line(
        "all six, pooled over windows",
        int(n.sum()),
        mean["idd"],
        mean["slip"],
        mean["ho"],
        mean["icr"],
    )


def line(name, n, idd, slip, ho, icr):
    def red(e):
        return f"{100 * (1 - e[0] / idd[0]):5.0f} {100 * (1 - e[1] / idd[1]):5.0f}"

    deg = np.degrees
    print(f"   {name:<34} {n:>4}  {idd[0]:6.3f} {deg(idd[1]):5.2f} | {slip[0]:6.3f}"
          f" {deg(slip[1]):5.2f} {red(slip)} | {ho[0]:14.3f} {deg(ho[1]):5.2f} {red(ho)} |"
          f" {icr[0]:9.3f} {deg(icr[1]):5.2f}")  # fmt: skip


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=REPO.parent / "shared" / "data" / "drive")
    args = parser.parse_args()
    sim_settling()
    sim_one_hz()
    if args.data.is_dir():
        real(args.data)


if __name__ == "__main__":
    main()
