"""Acceptance figures of the slip-parameter EKF (docs/results/slip_ekf.md).

1. Sec. 4.1 simulation, seeds 0-9 (the filter was tuned on seeds 100-109):
   settling time of the ICRs after the abrupt changes, with the change not
   signalled (the paper's filter) and with the terrain reset; the windowed
   measurement (``window`` 0.6 s) and the previous one-interval measurement
   (``window`` 0); an ideal batch estimator that knows the change time; and
   the windowed filter at 1 cm / 0.2 deg pose noise.
2. Sec. 4.2 simulation, pose 1 Hz / wheels 10 Hz: 2-s prediction errors of
   the slip EKF, the ICR EKF fed the same data, and ideal differential drive.
3. Real Warthog logs (../shared/data/drive), pose subsampled to 1 Hz (first
   pose of every whole second) for the filters; the 2-s windows start at those
   poses and end at the full-rate pose nearest 2 s later. The slip EKF uses
   config/warthog.yaml, tuned on the three logs marked ``T``. Then what
   constant models reach on the same windows (fitted on 2-s windows of the
   same log, or of the five others). Then the pose delay of every log
   (``terrain_odom.estimation.time_offset``, estimated on the full-rate log:
   ``--pose-delay auto``) and the same figures with it applied: the wheel
   speeds delayed by it, for the filters' input and the windows alike.
4. ``--speed`` (alone, ~1 min): ``run_slip_ekf`` over the grass log, us per
   row, best of 3, against the reference formulation (numpy and filterpy,
   ``FilterpySlipEkf``) timed alternately in the same run: first the kernels
   as plain Python (how a process runs its first ``PURE_CALLS`` kernel
   calls), then compiled by numba (loaded from its disk cache; compiled
   first if there is none); the states of both must agree to 1e-12.
5. ``--whole-run SRC`` (alone, ~30 s): ``terrain-odom run --estimator
   slip-ekf --no-plots`` over the grass log in fresh processes, this code and
   the package in ``SRC`` (e.g. ``git archive main src | tar -x -C /tmp/main``,
   then ``/tmp/main/src``) alternately,
   best of 3, and the largest difference of their ``trajectory.csv``;
   ``--rows N`` on the log's first ``N`` rows (start-up).

Usage::

    python bench/slip_ekf.py [--data ../shared/data/drive] [--speed] [--whole-run SRC [--rows N]]
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from unittest import mock

import numpy as np
from scipy.optimize import least_squares

from terrain_odom.config import Config, EkfConfig, IcrState, RobotConfig, load_config
from terrain_odom.estimation import _kernel_switch, slip_ekf
from terrain_odom.estimation.odometry import run_icr_ekf, run_slip_ekf
from terrain_odom.estimation.slip_ekf_reference import FilterpySlipEkf
from terrain_odom.estimation.time_offset import calibrate_pose_delay
from terrain_odom.evaluation import (
    Windows,
    icr_twist_from_rows,
    model_twist,
    non_overlapping,
    predict_window_ends,
    prediction_errors,
    prediction_windows,
    settling_time,
    slip_twist_from_rows,
    time_windows,
    window_errors,
)
from terrain_odom.fitting import (
    FitOptions,
    Horizon,
    fit_model,
    segment_set,
    training_windows,
)
from terrain_odom.io import read_wheel_log
from terrain_odom.kinematics import (
    get_model,
    integrate,
    relative_pose,
    twist_icr,
    twist_icr_jacobian,
    wrap_angle,
)
from terrain_odom.kinematics.integration import arc_increment_with_jacobian
from terrain_odom.kinematics.slip import SlipModel
from terrain_odom.sim.slip_scenario import TRACK_WIDTH, feature_slip_scenario, icr_switch_scenario
from terrain_odom.sim.slip_tuning import SEC41_SLIP_EKF, sec41_config

REPO = Path(__file__).resolve().parents[1]
TUNING_LOGS = (  # config/warthog.yaml slip_ekf was chosen on these; the others are held out
    "asphalt_2024_9_25_12h8s57",
    "grass_2024_7_18_16h59s20",
    "grass_2024_7_29_14h46s15",
)


# ---------------------------------------------------------------- 1. Sec. 4.1
def batch_icrs(
    log, t_from: float, t_to: float, start_icr, scale=(0.02, 0.02, 0.0087)
) -> np.ndarray:
    """Least-squares ICRs from the noisy poses in ``[t_from, t_to]`` (start pose free).

    ``start_icr`` is ``(y_l, y_r, x_icr)``, or with ``alpha`` to fit the slip
    factor too (in [0.3, 1.5]); ``scale`` the pose noise (m, m, rad) that
    weights the residuals. Returns the fitted ``y_l, y_r, x_icr``.
    """
    t = log.t
    rows = np.flatnonzero(log.has_pose & (t >= t_from - 1e-9) & (t <= t_to + 1e-9))
    a, b = rows[0], rows[-1]
    v_l, v_r, dt = log.v_l[a:b], log.v_r[a:b], np.diff(t[a : b + 1])
    measured = log.pose[rows]
    n = len(start_icr)

    def residual(q):
        poses = integrate(*twist_icr(v_l, v_r, *q[:n]), dt, start=q[n:])[rows - a]
        err = poses - measured
        err[:, 2] = wrap_angle(err[:, 2])
        return (err / np.asarray(scale)).ravel()

    lo = [0.05, -50.0, -10.0, 0.3][:n] + [-np.inf] * 3  # y_l > 0 > y_r
    hi = [50.0, -0.05, 10.0, 1.5][:n] + [np.inf] * 3
    return least_squares(residual, np.r_[start_icr, measured[0]], bounds=(lo, hi)).x[:3]


def batch_settling(sc, t_change: float, tol: float = 0.2) -> float:
    """Settling time of :func:`batch_icrs` run on growing spans after the change (<= 3 s)."""
    before = sc.icr[np.searchsorted(sc.log.t, t_change) - 1]
    truth = sc.icr[np.searchsorted(sc.log.t, t_change)]
    taus = np.round(np.arange(0.1, 3.001, 0.1), 1)
    inside = np.array(
        [
            np.all(np.abs(batch_icrs(sc.log, t_change, t_change + tau, before) - truth) <= tol)
            for tau in taus
        ]
    )
    outside = np.flatnonzero(~inside)
    return 0.0 if outside.size == 0 else float(taus[outside[-1] + 1])


def settling(res, sc, tol: float = 0.2) -> list[float]:
    t, icr = sc.log.t, res.states[:, 3:6]
    out = []
    for t_c in sc.changes:
        piece = (t >= t_c) & (t < t_c + 10.0)
        out.append(settling_time(t[piece], icr[piece], sc.icr[piece][-1], [tol] * 3, t_from=t_c))
    return out


def sim_settling(seeds=range(10)):
    """Print settling times (|ICR error| <= 0.2 m) of Sec. 4.1 per seed."""
    print("1. Sec. 4.1 abrupt ICR change (10 Hz pose), settling to |ICR error| <= 0.2 m, s,")
    print("   seeds 0-9: change at 2 s | change at 12 s  (count <= 1 s)")

    def show(name, rows):
        rows = np.asarray(rows)
        cells = [
            f"{np.round(rows[:, i], 1).tolist()} ({np.sum(rows[:, i] <= 1.0)}/10)"
            for i in range(rows.shape[1])
        ]
        print(f"   {name:<44} {' | '.join(cells)}")

    for window in (SEC41_SLIP_EKF.window, 0.0):
        for adapt in (False, True):
            cfg = sec41_config(adapt)
            cfg = dataclasses.replace(
                cfg, slip_ekf=dataclasses.replace(SEC41_SLIP_EKF, window=window)
            )
            rows = []
            for seed in seeds:
                sc = icr_switch_scenario(seed=seed)
                rows.append(settling(run_slip_ekf(sc.log, cfg, labels=sc.log.terrain), sc))
            reset = "terrain reset" if adapt else "not signalled"
            show(f"window {window:.1f} s, {reset}", rows)
    show(
        "batch least squares from the change on",
        [[batch_settling(icr_switch_scenario(seed=s), t_c) for t_c in (2.0, 12.0)] for s in seeds],
    )
    quiet = []
    for seed in seeds:
        sc = icr_switch_scenario(sigma_xy=0.01, sigma_yaw=np.radians(0.2), seed=seed)
        quiet.append(settling(run_slip_ekf(sc.log, sec41_config(False), labels=sc.log.terrain), sc))
    show(f"window {SEC41_SLIP_EKF.window:.1f} s, not signalled, 1 cm / 0.2 deg", quiet)


# ---------------------------------------------------------------- 2. Sec. 4.2
def errors(log, windows, twist):
    e = prediction_errors(log, windows, twist)
    return e.position, e.heading


def slip_twist(windows, res, cfg):
    """Twist callable of a slip EKF run's parameters (each window's start row)."""
    model = SlipModel.from_config(cfg.slip_ekf, cfg.robot.track_width)
    n = 6 + cfg.slip_ekf.estimate_alpha
    return slip_twist_from_rows(windows, res.states[:, 6 : 6 + n], model)


def slip_errors(log, filt_log, windows, cfg, labels=None):
    return errors(
        log, windows, slip_twist(windows, run_slip_ekf(filt_log, cfg, labels=labels), cfg)
    )


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


# ---------------------------------------------------------------- 3. real logs
def one_hz(log):
    """Keep the first pose of every whole second; return the log and those rows."""
    rows = np.flatnonzero(log.has_pose)
    sec = np.floor(log.t[rows])
    keep = rows[np.r_[True, sec[1:] != sec[:-1]]]
    pose = np.full_like(log.pose, np.nan)
    pose[keep] = log.pose[keep]
    return dataclasses.replace(log, pose=pose), keep


def constant_twist(model: SlipModel, params):
    """Twist callable of the slip model with constant parameters."""
    return lambda v_l, v_r, _i: model.twist(v_l, v_r, params)


def fit_slip_constant(logs, model: SlipModel) -> np.ndarray:
    """Constant ``l1 .. l6, alpha`` minimising the 2-s end-pose errors (Baril eq. 13, Sigma = I)."""
    wins = [non_overlapping(time_windows(log, 2.0)) for log in logs]

    def residual(p):
        out = []
        for log, w in zip(logs, wins, strict=True):
            end = predict_window_ends(log, w, constant_twist(model, p))
            err = relative_pose(log.pose[w.start], end) - relative_pose(
                log.pose[w.start], log.pose[w.end]
            )
            err[:, 2] = wrap_angle(err[:, 2])
            out.append(err.ravel())
        return np.concatenate(out)

    return least_squares(residual, np.r_[np.zeros(6), 1.0]).x


def fit_icr_slip(logs) -> np.ndarray:
    """Constant ``icr-slip`` model of ``terrain-odom fit`` on 2-s windows of ``logs``."""
    horizon = Horizon(2.0, "s")
    segments = segment_set(logs, [training_windows(log, horizon) for log in logs])
    return fit_model("icr-slip", segments, options=FitOptions(popsize=8, maxiter=100)).params


def filter_table(logs, cfg, title=True):
    """Per-log 2-s errors at 1-Hz pose; return the rows and, per log, the windows and runs."""
    b = cfg.robot.track_width
    if title:
        print(f"\n3. Real Warthog logs, pose 1 Hz, config/warthog.yaml (B = {b} m), 2-s errors,")
        print("   pose stamps as recorded; T: the slip_ekf section was tuned on this log")
    print(f"   {'log':<34} {'n':>4}  {'idd m':>6} {'deg':>5} | {'slip m':>6} {'deg':>5}"
          f" {'-%pos':>5} {'-%hdg':>5} | {'heading-only m':>14} {'deg':>5} {'-%pos':>5}"
          f" {'-%hdg':>5} | {'icr-ekf m':>9} {'deg':>5}")  # fmt: skip
    rows, runs = {}, {}
    for name, log in logs.items():
        sub, keep = one_hz(log)
        heading = dataclasses.replace(
            sub, pose=np.c_[np.full((len(log), 2), np.nan), sub.pose[:, 2]]
        )
        w = prediction_windows(log, starts=keep)
        res = run_slip_ekf(sub, cfg, labels=log.terrain)
        runs[name] = (w, res)
        rows[name] = (
            len(w),
            errors(log, w, model_twist(get_model("idd"), [], b)),
            errors(log, w, slip_twist(w, res, cfg)),
            slip_errors(log, heading, w, cfg, log.terrain),
            icr_errors(log, sub, w, cfg, log.terrain),
        )
        mark = " T" if name in TUNING_LOGS else ""
        line(name + mark, *rows[name])
    groups = {
        "all six, pooled over windows": list(logs),
        "the three held-out logs, pooled": [n for n in logs if n not in TUNING_LOGS],
        "the three tuning logs, pooled": list(TUNING_LOGS),
    }
    for title, names in groups.items():
        n = np.array([rows[k][0] for k in names])
        mean = [np.average([rows[k][i] for k in names], axis=0, weights=n) for i in range(1, 5)]
        line(title, int(n.sum()), *mean)
    return rows, runs


def reachable(logs, cfg, rows, runs):
    """Print what constant models and a per-window speed scale reach on the same windows."""
    b = cfg.robot.track_width
    model = SlipModel.from_config(cfg.slip_ekf, b)
    idd_model = get_model("idd")
    print("\n   What constant models reach on the same windows: 2-s position error reduction")
    print("   vs idd (%); fitted on the non-overlapping 2-s windows of the same log (in-sample)")
    print("   or of the five other logs; idd with the best speed scale (0.7-1.2) per window")
    print(f"   {'log':<34} {'slip EKF':>8} | {'slip model: same':>16} {'others':>6} |"
          f" {'icr-slip: same':>14} {'others':>6} | {'idd, scaled':>11}")  # fmt: skip
    pooled: dict[str, list] = {k: [] for k in ("idd", "ekf", "ss", "so", "is", "io", "sc")}
    for name, log in logs.items():
        w = runs[name][0]
        others = [v for k, v in logs.items() if k != name]
        idd = rows[name][1][0]
        consts = [
            fit_slip_constant([log], model),
            fit_slip_constant(others, model),
            fit_icr_slip([log]),
            fit_icr_slip(others),
        ]
        twists = [constant_twist(model, p) for p in consts[:2]] + [
            model_twist(get_model("icr-slip"), p) for p in consts[2:]
        ]
        pos = [prediction_errors(log, w, tw).position for tw in twists]
        best = np.full(len(w), np.inf)
        for scale in np.linspace(0.7, 1.2, 51):
            tw = model_twist(idd_model, [], b)
            err = window_errors(log, w, lambda v_l, v_r, i, s=scale, f=tw: f(s * v_l, s * v_r, i))
            best = np.minimum(best, err.translation)
        values = [idd, rows[name][2][0], *pos, float(best.mean())]
        for key, value in zip(pooled, values, strict=True):
            pooled[key].append((len(w), value))
        cells = [100 * (1 - e / idd) for e in values[1:]]
        print(f"   {name:<34} {cells[0]:8.0f} | {cells[1]:16.0f} {cells[2]:6.0f} |"
              f" {cells[3]:14.0f} {cells[4]:6.0f} | {cells[5]:11.0f}")  # fmt: skip
    mean = {k: np.average([v for _, v in r], weights=[n for n, _ in r]) for k, r in pooled.items()}
    cells = [100 * (1 - mean[k] / mean["idd"]) for k in ("ekf", "ss", "so", "is", "io", "sc")]
    print(f"   {'all six, pooled':<34} {cells[0]:8.1f} | {cells[1]:16.1f} {cells[2]:6.1f} |"
          f" {cells[3]:14.1f} {cells[4]:6.1f} | {cells[5]:11.1f}")  # fmt: skip


def where_the_gain_is(logs, cfg, runs):
    """Print the errors of the first 30 s of motion and later, and the final alpha."""
    b = cfg.robot.track_width
    print("\n   Mean 2-s position error (m) in the first 30 s of motion and after; final alpha")
    print(f"   {'log':<34} {'first 30 s: idd':>15} {'slip':>6} | {'later: idd':>10} {'slip':>6}"
          f" | {'alpha':>5}")  # fmt: skip
    for name, log in logs.items():
        w, res = runs[name]
        idd = window_errors(log, w, model_twist(get_model("idd"), [], b)).translation
        slip = window_errors(log, w, slip_twist(w, res, cfg)).translation
        moving = np.abs(log.v_l) + np.abs(log.v_r) > 0.1
        early = log.t[w.start] < log.t[np.argmax(moving)] + 30.0
        alpha = res.states[-1, 12] if cfg.slip_ekf.estimate_alpha else 1.0
        print(f"   {name:<34} {idd[early].mean():15.3f} {slip[early].mean():6.3f} |"
              f" {idd[~early].mean():10.3f} {slip[~early].mean():6.3f} | {alpha:5.3f}")  # fmt: skip


def residual_spread(logs, cfg):
    """Print the spread of the 1-s pose-change residuals of the constant slip model (sigma_r)."""
    model = SlipModel.from_config(cfg.slip_ekf, cfg.robot.track_width)
    tuning = [logs[k] for k in TUNING_LOGS]
    params = fit_slip_constant(tuning, model)
    res = []
    for log in tuning:
        _, keep = one_hz(log)
        w = Windows(start=keep[:-1], end=keep[1:], length=np.zeros(keep.size - 1))
        end = predict_window_ends(log, w, constant_twist(model, params))
        err = relative_pose(log.pose[w.start], end) - relative_pose(
            log.pose[w.start], log.pose[w.end]
        )
        err[:, 2] = wrap_angle(err[:, 2])
        moving = np.array([np.any(np.abs(log.v_l[i:j]) + np.abs(log.v_r[i:j]) > 0.1)
                           for i, j in zip(w.start, w.end, strict=True)])  # fmt: skip
        res.append(err[moving])
    res = np.concatenate(res)
    rms, med = np.sqrt(np.mean(res**2, axis=0)), np.median(np.abs(res), axis=0)
    print("\n   1-s pose-change residuals of the constant slip model fitted on the tuning logs,")
    print(f"   while moving (dx, dy m; dyaw rad): rms {rms[0]:.3f} {rms[1]:.3f} {rms[2]:.3f},"
          f" median |.| {med[0]:.3f} {med[1]:.3f} {med[2]:.3f}")  # fmt: skip


def calibrated_table(logs, cfg):
    """Print each log's pose delay, then the filter table and constant models with it applied."""
    b = cfg.robot.track_width
    model = SlipModel.from_config(cfg.slip_ekf, b)
    print("\n   Pose delay of each log (estimate_pose_delay on the full-rate log: heading changes")
    print("   over 0.5 s against the wheel yaw rate moved earlier; --pose-delay auto)")
    print(f"   {'log':<34} {'delay s':>7} {'+-':>6} {'yaw-rate scale':>14} {'changes':>7}")
    calibrated = {}
    for name, log in logs.items():
        calibrated[name], timing = calibrate_pose_delay(log, "auto", b)
        e = timing.estimate
        print(f"   {name:<34} {e.delay:7.3f} {e.std:6.3f} {e.yaw_rate_scale:14.3f} {e.pairs:7d}")
    print(
        "\n   With each log's pose delay applied (wheel speeds delayed; idd on the same windows):"
    )
    filter_table(calibrated, cfg, title=False)
    print("\n   Constant models with the delay applied, fitted on the same log (in-sample):")
    print("   2-s position error reduction vs idd (%)")
    print(f"   {'log':<34} {'slip model':>10} {'icr-slip':>8}")
    pooled = {k: [] for k in ("idd", "ss", "is")}
    for name, log in calibrated.items():
        _, keep = one_hz(log)
        w = prediction_windows(log, starts=keep)
        idd = prediction_errors(log, w, model_twist(get_model("idd"), [], b)).position
        slip_p, icr_p = fit_slip_constant([log], model), fit_icr_slip([log])
        ss = prediction_errors(log, w, constant_twist(model, slip_p)).position
        is_ = prediction_errors(log, w, model_twist(get_model("icr-slip"), icr_p)).position
        for key, value in zip(pooled, (idd, ss, is_), strict=True):
            pooled[key].append((len(w), value))
        print(f"   {name:<34} {100 * (1 - ss / idd):10.0f} {100 * (1 - is_ / idd):8.0f}")
    mean = {k: np.average([v for _, v in r], weights=[n for n, _ in r]) for k, r in pooled.items()}
    red = [100 * (1 - mean[k] / mean["idd"]) for k in ("ss", "is")]
    print(f"   {'all six, pooled':<34} {red[0]:10.1f} {red[1]:8.1f}")


def real(data: Path):
    cfg = load_config(REPO / "config" / "warthog.yaml")
    logs = {
        p.stem.replace("warthog_wheels_", ""): read_wheel_log(
            p, wheel_radius=cfg.robot.wheel_radius
        )
        for p in sorted(data.glob("warthog_wheels_*.csv"))
    }
    rows, runs = filter_table(logs, cfg)
    reachable(logs, cfg, rows, runs)
    where_the_gain_is(logs, cfg, runs)
    residual_spread(logs, cfg)
    calibrated_table(logs, cfg)


# ---------------------------------------------------------------- 4. speed
def einsum_pose_change_with_jacobian(model: SlipModel, params, v_l, v_r, dt):
    """Return what the former ``SlipModel.pose_change_with_jacobian`` did: one plain einsum."""
    v_l, v_r, dt = (np.atleast_1d(np.asarray(x, dtype=float)) for x in (v_l, v_r, dt))
    values, j_icr = model.icrs_with_jacobian(params, *model.features(v_l, v_r))
    twist = twist_icr(v_l, v_r, *values)
    _, j_arc = arc_increment_with_jacobian(*twist, dt)
    poses = integrate(*twist, dt)
    c, s = np.cos(poses[:-1, 2]), np.sin(poses[:-1, 2])
    j_comp = np.zeros((dt.size, 3, 3))
    j_comp[:, 0, 0], j_comp[:, 0, 1], j_comp[:, 1, 0], j_comp[:, 1, 1] = c, -s, s, c
    j_comp[:, 0, 2] = -(poses[-1, 1] - poses[1:, 1])
    j_comp[:, 1, 2] = poses[-1, 0] - poses[1:, 0]
    j_comp[:, 2, 2] = 1.0
    j_twist = twist_icr_jacobian(v_l, v_r, *values)
    return poses[-1], np.einsum("kab,kbc,kcd,kde->ae", j_comp, j_arc, j_twist, j_icr)


def speed(data: Path, repeats: int = 3):
    """Print us per row of ``run_slip_ekf`` on the grass log, kernels against the reference."""
    cfg = load_config(REPO / "config" / "warthog.yaml")
    log = read_wheel_log(data / "warthog_wheels_grass.csv", wheel_radius=cfg.robot.wheel_radius)
    reference = mock.patch.object(slip_ekf, "SlipEkf", FilterpySlipEkf)
    print(f"4. run_slip_ekf, grass log ({log.t.size} rows), best of {repeats}, us per row:")
    with mock.patch.object(_kernel_switch, "PURE_CALLS", 10**12):  # not compiled yet: Python
        speed_against_reference(log, cfg, reference, "kernels as Python", repeats)
    _kernel_switch.compile_kernels()
    run_slip_ekf(log, cfg)  # numba's cache loaded (or compiled) outside the timing
    speed_against_reference(log, cfg, reference, "compiled kernels", repeats)


def speed_against_reference(log, cfg, reference, name: str, repeats: int):
    """Time ``run_slip_ekf`` as it is and with ``reference`` patched in, alternately."""
    best = {"reference (numpy, filterpy)": np.inf, name: np.inf}
    states = {}
    for _ in range(repeats):
        for key in best:
            with reference if key.startswith("reference") else contextlib.nullcontext():
                start = time.perf_counter()
                states[key] = run_slip_ekf(log, cfg).states
                best[key] = min(best[key], time.perf_counter() - start)
    for key, sec in best.items():
        print(f"   {key:<28} {1e6 * sec / log.t.size:8.1f}")
    a, b = states.values()
    ratio = best["reference (numpy, filterpy)"] / best[name]
    print(f"   ratio {ratio:.2f}x; states differ by at most {np.nanmax(np.abs(a - b)):.1e}")


# ---------------------------------------------------------------- 5. whole run
def whole_run(data: Path, other_src: Path, rows: int | None = None, repeats: int = 3):
    """Print the best wall time of ``terrain-odom run`` with this code and with ``other_src``.

    ``rows``: only the log's first rows (a copy in a temporary folder).
    """
    best = {str(other_src): np.inf, "this code": np.inf}
    with tempfile.TemporaryDirectory() as tmp:
        wheels = data / "warthog_wheels_grass.csv"
        if rows is not None:
            lines = wheels.read_text().splitlines(keepends=True)[: rows + 1]
            wheels = Path(tmp) / "wheels.csv"
            wheels.write_text("".join(lines))
        for i in range(repeats):
            for j, name in enumerate(best):
                src = REPO / "src" if name == "this code" else Path(name).resolve()
                command = [sys.executable, "-m", "terrain_odom", "run", "--estimator"]
                command += ["slip-ekf", "--no-plots", "--config", str(REPO / "config/warthog.yaml")]
                command += ["--wheels", str(wheels)]
                command += ["--out", str(Path(tmp) / f"{i}-{j}")]
                env = {**os.environ, "PYTHONPATH": str(src)}
                start = time.perf_counter()
                done = subprocess.run(command, env=env, capture_output=True, text=True)
                if done.returncode:
                    raise SystemExit(f"{name}: {' '.join(command)} failed:\n{done.stderr}")
                best[name] = min(best[name], time.perf_counter() - start)
        a, b = (
            np.genfromtxt(Path(tmp) / f"0-{j}" / "trajectory.csv", delimiter=",", names=True)
            for j in range(2)
        )
    diff = max(np.nanmax(np.abs(a[c] - b[c]), initial=0.0) for c in a.dtype.names)
    what = "grass log" if rows is None else f"first {rows} rows of the grass log"
    print(f"5. terrain-odom run --estimator slip-ekf --no-plots, {what}, best of {repeats}:")
    for name, sec in best.items():
        print(f"   {name:<40} {sec:6.2f} s")
    ratio = best[str(other_src)] / best["this code"]
    print(f"   ratio {ratio:.2f}x; trajectory.csv columns differ by at most {diff:.1e}")


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
    parser.add_argument("--speed", action="store_true", help="only section 4 (timing)")
    parser.add_argument("--whole-run", type=Path, metavar="SRC", help="only section 5")
    parser.add_argument("--rows", type=int, help="section 5 on the log's first rows only")
    args = parser.parse_args()
    if args.speed:
        speed(args.data)
    if args.whole_run:
        whole_run(args.data, args.whole_run, args.rows)
    if args.speed or args.whole_run:
        return
    sim_settling()
    sim_one_hz()
    if args.data.is_dir():
        real(args.data)


if __name__ == "__main__":
    main()
