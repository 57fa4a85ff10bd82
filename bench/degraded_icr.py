"""The ICR EKF on degraded real logs: ICR end states and outage errors against ideal diff drive.

Degrades a Warthog DRIVE log (``terrain_odom.sim.degrade``: GPS at 2.5 Hz,
0.8 m noise plus a random walk, 0.5 s late, antenna 1 m behind; with
``--imu`` an IMU heading at 50 Hz, 2.7 rad off, a 15-deg slow wander) for
each seed, runs the ICR EKF with what a user has after calibration (the
mounting known, the noise the messages claim: 0.8 m, 0.035 rad; ``--ekf``
overrides ``ekf`` keys), and prints per seed the ICRs at the end and the
median end-position error of dead reckoning over 30-s and 60-s outage
windows: from the true pose at each start (every 5 s, where the robot
drives at least 0.1 m/s on average), the logged wheel speeds integrated with
the ICRs the filter had there, frozen, beside the same with ideal
differential drive (``+-B / 2``), and their ratio. Also the track's RMS
error against the truth, the largest error before the heading is known
(GPS alone: before it is taken from the course) and the pose counts.

Usage::

    python bench/degraded_icr.py [--log ../shared/data/drive/warthog_wheels_grass.csv]
                                 [--seeds 0 1 2] [--imu] [--ekf "{sigma_r: {yaw: 3.0}}"]
                                 [--delay 0.5]

About 10-30 s a seed. With ``PYTHONPATH`` pointing at another checkout's
``src`` (that has ``sim/degrade.py``), the same figures for that version.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
import yaml

from terrain_odom.config import load_config
from terrain_odom.estimation.odometry import run_odometry
from terrain_odom.estimation.online import OnlineOdometry
from terrain_odom.estimation.time_offset import delay_wheel_speeds
from terrain_odom.io import read_wheel_log
from terrain_odom.kinematics import integrate, twist_icr
from terrain_odom.records import WheelLog
from terrain_odom.sim.degrade import Degradation, degrade_log

REPO = Path(__file__).resolve().parents[1]
TRACK_WIDTH = 1.08  # m, the Warthog's nominal track (config/warthog.yaml)


def _truth(clean: WheelLog, t: np.ndarray) -> np.ndarray:
    """Return the clean log's pose interpolated at ``t`` (yaw unwrapped), shape (len(t), 3)."""
    rows = np.flatnonzero(clean.has_pose)
    yaw = np.unwrap(clean.pose[rows, 2])
    return np.column_stack([np.interp(t, clean.t[rows], c) for c in (*clean.pose[rows, :2].T, yaw)])


def outage(
    log: WheelLog, clean: WheelLog, states: np.ndarray, names: list[str], seconds: float
) -> tuple[float, float, int]:
    """Median end-position error (m) of the learned ICRs and of ideal diff drive; windows."""
    icr = [names.index(n) for n in ("y_l", "y_r", "x_icr")]
    alpha = names.index("alpha") if "alpha" in names else None
    pairs = []
    for start in np.arange(log.t[0] + 5.0, log.t[-1] - seconds, 5.0):
        k0, k1 = np.searchsorted(log.t, [start, start + seconds])
        t, v_l, v_r = log.t[k0 : k1 + 1], log.v_l[k0:k1], log.v_r[k0:k1]
        if np.sum(np.abs(v_l + v_r) / 2.0 * np.diff(t)) < 0.1 * seconds:
            continue  # standing: every model is right
        ends = _truth(clean, t[[0, -1]])
        learned = (*states[k0, icr], 1.0 if alpha is None else states[k0, alpha])
        half = TRACK_WIDTH / 2.0
        pair = []
        for params in (learned, (half, -half, 0.0, 1.0)):
            twist = twist_icr(v_l, v_r, *params)
            pose = integrate(*twist, np.diff(t), start=ends[0])[-1]
            pair.append(float(np.hypot(*(pose[:2] - ends[1, :2]))))
        pairs.append(pair)
    median = np.median(pairs, axis=0)
    return float(median[0]), float(median[1]), len(pairs)


def _config(ekf: dict, delay: float, folder: Path) -> Path:
    """Write the run's configuration: the Warthog, claimed noise, the true mounting."""
    data = {
        "robot": {"wheel_radius": 0.30, "track_width": TRACK_WIDTH},
        "ekf": {"sigma_r": {"x": 0.8, "y": 0.8, "yaw": 0.035}, **ekf},
        "pose_sensor": {"antenna_x": -1.0, "antenna_y": 0.0, "heading_offset": 2.7},
        "time": {"pose_delay": delay},
    }
    path = folder / "config.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    drive = REPO.parent / "shared" / "data" / "drive"
    parser.add_argument("--log", type=Path, default=drive / "warthog_wheels_grass.csv")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--imu", action="store_true", help="an IMU heading at 50 Hz too")
    parser.add_argument("--ekf", default="{}", help="YAML mapping of ekf keys to override")
    parser.add_argument("--delay", type=float, default=0.0, help="time.pose_delay, s")
    args = parser.parse_args()
    clean = read_wheel_log(args.log, wheel_radius=0.30)
    with tempfile.TemporaryDirectory() as folder:
        cfg = load_config(_config(yaml.safe_load(args.ekf), args.delay, Path(folder)))
    print(f"{args.log.name}, GPS{' + IMU' if args.imu else ' alone'}, ekf {args.ekf}")
    for seed in args.seeds:
        degraded = degrade_log(clean, Degradation(imu_rate=50.0 if args.imu else 0.0, seed=seed))
        log = delay_wheel_speeds(degraded.log, args.delay) if args.delay else degraded.log
        odo = OnlineOdometry(cfg)
        result = run_odometry(log, odo)
        names = list(odo.names)
        end = dict(zip(names, result.states[-1], strict=True))
        errors = np.hypot(*(result.states[:, :2] - _truth(clean, log.t)[:, :2]).T)
        unknown = result.stds[:, 2] > 0.3  # no heading yet
        figures = [f"seed {seed}: end y_l {end['y_l']:+.2f} y_r {end['y_r']:+.2f}"
                   f" x_icr {end['x_icr']:+.2f} alpha {end.get('alpha', 1.0):.2f}"]  # fmt: skip
        for seconds in (30.0, 60.0):
            learned, ideal, windows = outage(log, clean, result.states, names, seconds)
            figures.append(
                f"{seconds:.0f} s: {learned:.2f} m vs idd {ideal:.2f} m = {learned / ideal:.2f}x"
                f" ({windows} windows)"
            )
        before = f"{errors[unknown].max():.2f} m" if unknown.any() else "-"
        figures.append(f"track rms {np.sqrt(np.mean(errors**2)):.2f} m, before a heading {before}")
        print(" | ".join(figures))
        print(f"        pose: {odo.pose_use.summary()}")


if __name__ == "__main__":
    main()
