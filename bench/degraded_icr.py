"""The ICR EKF on degraded real logs: ICRs, outage errors against ideal diff drive, heading bias.

Degrades Warthog DRIVE logs (``terrain_odom.sim.degrade``: GPS at 2.5 Hz,
0.8 m noise plus a random walk, 0.5 s late, antenna 1 m behind; with
``--imu`` an IMU heading at 50 Hz, 2.7 rad off, an Ornstein-Uhlenbeck wander
of std 15 deg and time constant 30 s, 1.1 deg white noise) for each seed, runs
the ICR EKF with what a user has after calibration (the mounting known, the
noise the messages claim: 0.8 m, 0.035 rad; ``--ekf`` overrides ``ekf``
keys), with ``pose_sensor.heading_bias`` off and on (``--bias off on``; the
bias's std is the heading wander that
:func:`~terrain_odom.evaluation.calibration.fit_sensors` estimates from the
degraded log, its time constant ``--wander-time``), and prints per log, seed
and setting:

- the ICRs at the end and the share of the second half's rows with
  ``|x_icr|`` at its bound;
- the median end-position error of dead reckoning over 30-s and 60-s outage
  windows: from the true pose at each start (every 5 s, where the robot
  drives at least 0.1 m/s on average, the window within one run of the log),
  the logged wheel speeds integrated with the ICRs the filter had there,
  frozen, beside the same with ideal differential drive (``+-B / 2``), and
  their ratio;
- with the bias: the RMS of the estimated bias against the injected
  disturbance (the measured heading minus the true yaw and the offset: the
  wander plus the 1.1-deg white noise, at the heading rows), beside the RMS
  of the disturbance itself (what a zero estimate scores), and the bias's
  std at the end;
- the track's RMS error against the truth and the pose counts;

then per log and setting the spread (std) of the end ICRs across seeds.
The gravel log is 300 separate 2-s windows: no outage window fits in one.

Usage::

    python bench/degraded_icr.py [--log LOG ...] [--seeds 0 1 2] [--imu]
                                 [--bias off on] [--wander-time 30]
                                 [--ekf "{sigma_r: {yaw: 3.0}}"] [--delay 0.5]

About 15 s for the 5 logs x 3 seeds x 2 settings at load 5 on the 2 cores.
With ``PYTHONPATH`` pointing at another checkout's ``src`` (that has
``sim/degrade.py``), the same figures for that version (``--bias off`` there).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
import yaml

from terrain_odom.config import Config, load_config
from terrain_odom.estimation.odometry import run_odometry
from terrain_odom.estimation.online import OnlineOdometry
from terrain_odom.estimation.time_offset import delay_wheel_speeds
from terrain_odom.evaluation.calibration import fit_sensors
from terrain_odom.io import read_wheel_log
from terrain_odom.kinematics import integrate, twist_icr, wrap_angle
from terrain_odom.records import WheelLog
from terrain_odom.sim.degrade import Degradation, DegradedLog, degrade_log

REPO = Path(__file__).resolve().parents[1]
DRIVE = REPO.parent / "shared" / "data" / "drive"
LOGS = (
    "warthog_wheels_grass.csv",
    "warthog_wheels_grass_2024_7_18_16h59s20.csv",
    "warthog_wheels_grass_2024_7_29_14h46s15.csv",
    "warthog_wheels_asphalt_2024_9_25_12h8s57.csv",
    "windows_warthog_gravel.csv",
)
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
    runs = log.segment_runs()
    pairs = []
    for start in np.arange(log.t[0] + 5.0, log.t[-1] - seconds, 5.0):
        k0, k1 = np.searchsorted(log.t, [start, start + seconds])
        t, v_l, v_r = log.t[k0 : k1 + 1], log.v_l[k0:k1], log.v_r[k0:k1]
        if runs[k0] != runs[min(k1, len(log) - 1)]:
            continue  # across a break of the log: no truth between
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
    if not pairs:
        return float("nan"), float("nan"), 0
    median = np.median(pairs, axis=0)
    return float(median[0]), float(median[1]), len(pairs)


def bias_error(degraded: DegradedLog, states: np.ndarray, names: list[str]) -> tuple[float, float]:
    """RMS of the estimated heading bias and of zero against the injected disturbance, rad.

    The disturbance at a heading row is the measured heading minus the true
    yaw (at the IMU's latency) and the offset: the wander plus white noise.
    """
    log, injected = degraded.log, degraded.injected
    rows = np.flatnonzero(log.has_yaw)
    true_yaw = _truth(degraded.truth, log.t[rows] - injected["imu_latency"])[:, 2]
    wander = wrap_angle(log.pose[rows, 2] - true_yaw - injected["heading_offset"])
    estimate = states[rows, names.index("heading_bias")]
    return float(np.sqrt(np.mean(wrap_angle(estimate - wander) ** 2))), float(
        np.sqrt(np.mean(wander**2))
    )


def _config(ekf: dict, delay: float, folder: Path) -> Config:
    """Return the run's configuration: the Warthog, claimed noise, the true mounting."""
    data = {
        "robot": {"wheel_radius": 0.30, "track_width": TRACK_WIDTH},
        "ekf": {"sigma_r": {"x": 0.8, "y": 0.8, "yaw": 0.035}, **ekf},
        "pose_sensor": {"antenna_x": -1.0, "antenna_y": 0.0, "heading_offset": 2.7},
        "time": {"pose_delay": delay},
    }
    path = folder / "config.yaml"
    path.write_text(yaml.safe_dump(data))
    return load_config(path)


def _with_bias(cfg: Config, on: bool, wander: float, tau: float) -> Config:
    sensor = cfg.pose_sensor
    changes = {"heading_bias": on, "heading_wander": wander, "wander_time": tau} if on else {}
    return Config(**{**vars(cfg), "pose_sensor": type(sensor)(**{**vars(sensor), **changes})})


def run_one(
    degraded: DegradedLog, cfg: Config, delay: float, bound: float
) -> tuple[list[str], dict[str, float]]:
    """Run the filter on a degraded log; return the printed figures and the end ICRs."""
    log = delay_wheel_speeds(degraded.log, delay) if delay else degraded.log
    odo = OnlineOdometry(cfg)
    result = run_odometry(log, odo)
    names = list(odo.names)
    end = dict(zip(names, result.states[-1], strict=True))
    half = result.states[len(log) // 2 :, names.index("x_icr")]
    pinned = float(np.mean(np.abs(half) >= 0.999 * bound))
    figures = [f"end y_l {end['y_l']:+.2f} y_r {end['y_r']:+.2f} x_icr {end['x_icr']:+.2f}"
               f" alpha {end.get('alpha', 1.0):.2f}, x_icr at bound {100 * pinned:.0f} %"]  # fmt: skip
    for seconds in (30.0, 60.0):
        learned, ideal, windows = outage(log, degraded.truth, result.states, names, seconds)
        figures.append(
            f"{seconds:.0f} s: {learned:.2f} m vs idd {ideal:.2f} m = {learned / ideal:.2f}x"
            f" ({windows})"
            if windows
            else f"{seconds:.0f} s: no window"
        )
    if "heading_bias" in names:
        rms, zero = bias_error(degraded, result.states, names)
        std = result.stds[-1, names.index("heading_bias")]
        figures.append(
            f"bias rms {np.degrees(rms):.1f} deg (zero {np.degrees(zero):.1f}), "
            f"std {np.degrees(std):.1f} deg"
        )
    errors = np.hypot(*(result.states[:, :2] - _truth(degraded.truth, log.t)[:, :2]).T)
    figures.append(f"track rms {np.sqrt(np.mean(errors**2)):.2f} m")
    return figures, end


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--log", type=Path, nargs="+", default=[DRIVE / n for n in LOGS])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--imu", action="store_true", help="an IMU heading at 50 Hz too")
    parser.add_argument("--bias", nargs="+", choices=("off", "on"), default=["off", "on"])
    parser.add_argument("--wander-time", type=float, default=30.0, help="its time constant, s")
    parser.add_argument("--ekf", default="{}", help="YAML mapping of ekf keys to override")
    parser.add_argument("--delay", type=float, default=0.0, help="time.pose_delay, s")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        cfg = _config(yaml.safe_load(args.ekf), args.delay, Path(folder))
    bound = cfg.ekf.limits.resolve(cfg.robot).x_icr_max
    print(f"GPS{' + IMU' if args.imu else ' alone'}, ekf {args.ekf}, |x_icr| <= {bound:.2f} m")
    for path in args.log:
        clean = read_wheel_log(path, wheel_radius=0.30)
        ends: dict[str, list[dict[str, float]]] = {setting: [] for setting in args.bias}
        for seed in args.seeds:
            degraded = degrade_log(
                clean, Degradation(imu_rate=50.0 if args.imu else 0.0, seed=seed)
            )
            wander = fit_sensors(degraded.log, TRACK_WIDTH).heading_wander if args.imu else None
            for setting in args.bias:
                on = setting == "on" and wander is not None
                sigma = wander.value if on and wander.observable else 0.17  # type: ignore[union-attr]
                run_cfg = _with_bias(cfg, on, sigma, args.wander_time)
                figures, end = run_one(degraded, run_cfg, args.delay, bound)
                ends[setting].append(end)
                label = f"bias {setting}" + (f" ({np.degrees(sigma):.1f} deg)" if on else "")
                print(f"{path.name[:32]:32s} seed {seed} {label}: " + " | ".join(figures))
        for setting, rows in ends.items():
            spread = {k: float(np.std([r[k] for r in rows])) for k in ("y_l", "y_r", "x_icr")}
            print(
                f"{path.name[:32]:32s} bias {setting}: spread across seeds "
                + " ".join(f"{k} {v:.2f}" for k, v in spread.items())
                + " m"
            )


if __name__ == "__main__":
    main()
