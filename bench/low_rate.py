"""Low-rate pose (1 Hz): the ICR EKF against the slip EKF on every real log (docs/results/slip_ekf.md).

Every wheel log in ``../shared/data/drive`` is read with ``config/warthog.yaml``;
the filters get the first pose of every whole second (1 Hz: a GPS with an
IMU heading), the 2-s prediction windows start at those poses and end at the
full-rate pose nearest 2 s later (``evaluation.prediction_windows``); the
prediction uses the parameters each filter held at the window's start. Rows:

- ``idd``: ideal differential drive (the baseline);
- ``icr-ekf``: the ICR EKF as configured (its initial ICRs fitted offline
  on the asphalt log);
- ``icr-ekf, idd start``: the same filter started from ideal differential
  drive (``y = +-B/2``, ``x_icr = 0``, ``alpha = 1``), as the slip EKF starts
  from no slip: the two differ then only in the model and the measurement;
- ``slip-ekf``: the slip EKF as configured.

Then, to find out why one wins, the same windows pooled over all logs by
the curvature feature of their track speeds (``k = |v_r - v_l| / (|v_l| +
|v_r|)``, mean over the window): the slip model's ICRs are ``+-B/2`` plus
terms proportional to its features, so in gentle curves it falls back to
ideal differential drive, while a skid-steer robot's ICRs stay wide.

Usage::

    python bench/low_rate.py [--data ../shared/data/drive]
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np
from slip_ekf import one_hz, slip_twist  # bench/slip_ekf.py: the same 1-Hz windows and twist

from terrain_odom.config import IcrState, load_config
from terrain_odom.estimation.odometry import run_icr_ekf, run_slip_ekf
from terrain_odom.evaluation import (
    icr_twist_from_rows,
    model_twist,
    predict_window_ends,
    prediction_windows,
    window_errors,
)
from terrain_odom.io import read_wheel_log
from terrain_odom.kinematics import get_model, wrap_angle

REPO = Path(__file__).resolve().parents[1]
NAMES = ("idd", "icr-ekf", "icr-ekf, idd start", "slip-ekf")
BINS = (0.0, 0.05, 0.15, 0.4, 1.01)  # curvature feature k


def icr_twist(windows, result):
    """Twist callable of an ICR EKF run (each window's start row)."""
    c = dict(zip(result.names, result.states.T, strict=True))
    return icr_twist_from_rows(windows, c["y_l"], c["y_r"], c["x_icr"], c.get("alpha", 1.0))


def per_window(log, cfg, idd_cfg):
    """2-s errors of every estimator on one log's 1-Hz windows, and each window's curvature."""
    sub, keep = one_hz(log)
    w = prediction_windows(log, starts=keep)
    b = cfg.robot.track_width
    twists = {
        "idd": model_twist(get_model("idd"), [], b),
        "icr-ekf": icr_twist(w, run_icr_ekf(sub, cfg)),
        "icr-ekf, idd start": icr_twist(w, run_icr_ekf(sub, idd_cfg)),
        "slip-ekf": slip_twist(w, run_slip_ekf(sub, cfg), cfg),
    }
    errors = {}
    start_yaw = log.pose[w.start, 2]
    measured = wrap_angle(log.pose[w.end, 2] - start_yaw)
    for name, twist in twists.items():
        err = window_errors(log, w, twist)
        predicted = wrap_angle(predict_window_ends(log, w, twist)[:, 2] - start_yaw)
        errors[name] = np.c_[err.translation, np.degrees(err.rotation), predicted, measured]
    k = np.abs(log.v_r - log.v_l) / (np.abs(log.v_l) + np.abs(log.v_r) + 1e-3)
    curvature = np.array([k[a:e].mean() for a, e in zip(w.start, w.end, strict=True)])
    return errors, curvature


def row(title, errors, turn=False):
    """One table row: windows, then position m and heading deg of each estimator.

    With ``turn``, also the least-squares ratio of predicted to measured
    heading change (1: the model turns as much as the robot).
    """
    n = len(errors["idd"])
    cells = []
    for e in NAMES:
        err = errors[e]
        cell = f"{err[:, 0].mean():6.3f} {err[:, 1].mean():5.2f}"
        if turn:
            cell += f" x{err[:, 2] @ err[:, 3] / (err[:, 3] @ err[:, 3]):4.2f}"
        cells.append(cell)
    print(f"   {title:<42} {n:>5} | {' | '.join(cells)}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=REPO.parent / "shared" / "data" / "drive")
    args = parser.parse_args()
    cfg = load_config(REPO / "config" / "warthog.yaml")
    half = cfg.robot.track_width / 2
    start = IcrState(y_l=half, y_r=-half, x_icr=0.0, alpha=1.0)
    idd_cfg = dataclasses.replace(cfg, ekf=dataclasses.replace(cfg.ekf, initial=start))
    print("Pose 1 Hz, config/warthog.yaml, mean 2-s prediction error: position m, heading deg")
    header = " | ".join(f"{name[:13]:>12}" for name in NAMES)
    print(f"   {'log':<42} {'n':>5} | {header}")
    pooled, curvature, windowed = [], [], []
    for path in sorted(args.data.glob("*.csv")):
        log = read_wheel_log(path, wheel_radius=cfg.robot.wheel_radius)
        errors, k = per_window(log, cfg, idd_cfg)
        row(path.stem.replace("warthog_wheels_", ""), errors)
        pooled.append(errors)
        curvature.append(k)
        windowed.append(log.n_runs > 1)  # the 2-s window files of DRIVE
    continuous = [not w for w in windowed]

    def pooled_over(mask):
        chosen = [p for p, x in zip(pooled, mask, strict=True) if x]
        return {e: np.concatenate([p[e] for p in chosen]) for e in NAMES}

    row("continuous logs, pooled over windows", pooled_over(continuous))
    row("2-s window logs (DRIVE protocol), pooled", pooled_over(windowed))
    pool = pooled_over(continuous)
    k = np.concatenate([c for c, x in zip(curvature, continuous, strict=True) if x])
    print("\nContinuous logs' windows by curvature feature k of the track speeds; x: predicted /")
    print("measured heading change (least squares)")
    for low, high in zip(BINS[:-1], BINS[1:], strict=True):
        inside = (k >= low) & (k < high)
        row(f"{low:.2f} <= k < {high:.2f}", {e: pool[e][inside] for e in NAMES}, turn=True)


if __name__ == "__main__":
    main()
