"""Offline model identification on the real Warthog logs (../shared/data/drive).

Prints every figure of docs/results/identification.md:

1. the fit time of the 5-parameter asymmetric model (edd-asym) on ~10 min of
   grass log (the two longest runs), default optimiser settings;
2. held-out error per metre (h_e = 2 m, median [q25-q75]) on the five grass
   runs, leave-one-run-out: each run is evaluated with the model fitted on the
   four others, and the held-out windows of the five folds are pooled; plus
   edd-sym fitted on all five runs and evaluated on them (the optimistic oracle);
3. the asphalt and gravel window files split by window id: fitted on the
   even windows, evaluated on the odd ones;
4. the per-terrain comparison (``compare --by-terrain``): grass runs 1, 3, 5
   + even asphalt and gravel windows for training, grass runs 2, 4 + odd
   windows for evaluation; Markdown, JSON, box plot and parameter files go to --out.

Usage::

    taskset -c 0 python bench/fit.py [--data ../shared/data/drive] [--out /tmp/fit-bench]

Takes about two minutes on one core. With ``--speed`` it prints only the
speed-up of the fit (issue 15): figure 1's fit, timed with the pose
integration as it was (arc coefficients with every term of both branches on
every angle, increments stacked then sliced: the baseline) and as it is,
alternately, best of ``--repeat``; the fitted parameters must be bit-identical.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from terrain_odom.app.fit import compare, fit
from terrain_odom.config import load_config
from terrain_odom.evaluation import model_twist, spatial_windows, summarize, window_errors
from terrain_odom.fitting import loss
from terrain_odom.io import read_wheel_log
from terrain_odom.kinematics import MODELS, get_model, integration
from terrain_odom.records import WheelLog

REPO = Path(__file__).resolve().parents[1]


def select_segments(log: WheelLog, parity: int) -> WheelLog:
    """Rows of the windows whose ``segment`` id has the given parity (0 even, 1 odd)."""
    keep = log.segment % 2 == parity
    return log.take(keep, f"{log.source}[{'odd' if parity else 'even'} windows]")


def held_out(name, params, logs, track_width):
    """Window errors of a constant model on each log."""
    model = get_model(name)
    return [
        window_errors(log, spatial_windows(log), model_twist(model, params, track_width))
        for log in logs
    ]


def cell(summary):
    t, r = summary.translation, summary.rotation
    return f"{t.median:.4f} [{t.q25:.3f}-{t.q75:.3f}] | {r.median:.3f} [{r.q25:.2f}-{r.q75:.2f}]"


def loro(grass, cfg):
    """Leave-one-run-out on the grass runs: pooled held-out errors per model."""
    b = cfg.robot.track_width
    print("\nGrass, leave-one-run-out (fit on 4 runs, evaluate on the 5th; 5 folds pooled)")
    print("| model | held-out m/m | held-out deg/m | parameters per fold | fit (s) |")
    print("|---|---|---|---|---|")
    for name in MODELS:
        errors, params, seconds = [], [], 0.0
        for i, test in enumerate(grass):
            train = [g for j, g in enumerate(grass) if j != i]
            report = fit(train, name, config=cfg)
            p = report.params.vector()
            params.append(p)
            seconds += sum(report.seconds.values())
            errors += held_out(name, p, [test], b)
        spread = " / ".join(np.array2string(p, precision=3, separator=" ") for p in params[:2])
        print(f"| {name} | {cell(summarize(errors))} | {spread} ... | {seconds / 5:.1f} |")
    oracle = fit(grass, "edd-sym", config=cfg)
    print(
        f"edd-sym fitted on all five runs, evaluated on them: "
        f"{cell(summarize(held_out('edd-sym', oracle.params.vector(), grass, b)))} "
        f"({oracle.params.sets['*'].params})"
    )


def windows_split(window_logs, cfg):
    """Fit on even windows, evaluate on odd ones, per window file."""
    b = cfg.robot.track_width
    print("\nWindow files: fit on even window ids, evaluate on odd ones (h_e = 2 m)")
    print("| terrain | model | held-out m/m | held-out deg/m | parameters |")
    print("|---|---|---|---|---|")
    for terrain, log in window_logs.items():
        train, test = select_segments(log, 0), select_segments(log, 1)
        for name in MODELS:
            report = fit([train], name, config=cfg)
            p = report.params.vector()
            s = summarize(held_out(name, p, [test], b))
            print(f"| {terrain} | {name} | {cell(s)} | {np.array2string(p, precision=3)} |")


def fit_time(grass, cfg):
    """Fit time of edd-asym on the two longest grass runs (~10 min)."""
    runs = sorted(grass, key=lambda g: -g.t[-1])[:2]
    minutes = sum(float(g.t[-1] - g.t[0]) for g in runs) / 60.0
    report = fit(runs, "edd-asym", config=cfg)
    f = report.params.sets["*"].fit
    print(
        f"edd-asym on {minutes:.1f} min of grass log ({int(f['segments'])} segments of 2 m, "
        f"{f['length_m']:.0f} m): fitted in {f['seconds']:.1f} s "
        f"(loss {f['loss']:.3f}; {report.params.sets['*'].params})"
    )


def former_arc_coefficients(phi, derivatives=True):
    """Return the arc coefficients as computed before issue 15 (the baseline of ``--speed``)."""
    small = np.abs(phi) < integration._SERIES_LIMIT
    p = np.where(small, 1.0, phi)
    p2 = phi * phi
    a = np.where(small, 1.0 - p2 / 6.0 + p2 * p2 / 120.0, np.sin(p) / p)
    b = np.where(small, phi / 2.0 - phi * p2 / 24.0 + phi * p2 * p2 / 720.0, (1.0 - np.cos(p)) / p)
    da = np.where(small, -phi / 3.0 + phi * p2 / 30.0, (p * np.cos(p) - np.sin(p)) / (p * p))
    db = np.where(
        small, 0.5 - p2 / 8.0 + p2 * p2 / 144.0, (p * np.sin(p) - (1.0 - np.cos(p))) / (p * p)
    )
    return (a, b, da, db) if derivatives else (a, b)


def former_integrate(v_x, v_y, omega, dt, *, start=None):
    """Return ``integrate`` as computed before issue 15 (through the stacked increments)."""
    inc = integration.arc_increment(v_x, v_y, omega, dt)
    lead = inc.shape[:-2]
    start_pose = np.zeros(lead + (3,)) if start is None else np.broadcast_to(start, lead + (3,))
    yaw = start_pose[..., None, 2] + np.concatenate(
        [np.zeros(lead + (1,)), np.cumsum(inc[..., 2], axis=-1)], axis=-1
    )
    c, s = np.cos(yaw[..., :-1]), np.sin(yaw[..., :-1])
    dx = c * inc[..., 0] - s * inc[..., 1]
    dy = s * inc[..., 0] + c * inc[..., 1]
    zero = np.zeros(lead + (1,))
    x = start_pose[..., None, 0] + np.concatenate([zero, np.cumsum(dx, axis=-1)], axis=-1)
    y = start_pose[..., None, 1] + np.concatenate([zero, np.cumsum(dy, axis=-1)], axis=-1)
    return np.stack([x, y, integration.wrap_angle(yaw)], axis=-1)


def fit_speed(grass, cfg, repeat):
    """Figure 1's fit with the former and the current pose integration, same process."""
    runs = sorted(grass, key=lambda g: -g.t[-1])[:2]
    current = (integration._arc_coefficients, loss.integrate)
    versions = {"former": (former_arc_coefficients, former_integrate), "current": current}
    times = {name: [] for name in versions}
    params = {}
    for _ in range(repeat):
        for name, (coefficients, integrate) in versions.items():
            integration._arc_coefficients, loss.integrate = coefficients, integrate
            started = time.perf_counter()
            report = fit(runs, "edd-asym", config=cfg)
            times[name].append(time.perf_counter() - started)
            params[name] = report.params.vector()
    integration._arc_coefficients, loss.integrate = current
    same = params["former"].tobytes() == params["current"].tobytes()
    former, now = min(times["former"]), min(times["current"])
    print(f"fit edd-asym on the two longest grass runs, best of {repeat}:")
    print(f"  former pose integration (baseline) {former:6.2f} s")
    print(
        f"  current                            {now:6.2f} s = {100 * (1 - now / former):.0f} % "
        f"less time ({former / now:.2f}x faster); parameters bit-identical: {same}"
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--data", default=str(REPO.parent / "shared" / "data" / "drive"))
    parser.add_argument("--config", default=str(REPO / "config" / "warthog.yaml"))
    parser.add_argument("--out", default="/tmp/terrain-odom-fit-bench")
    parser.add_argument("--speed", action="store_true", help="only the fit's speed-up")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    data = Path(args.data)
    cfg = load_config(args.config)
    started = time.perf_counter()
    r = cfg.robot.wheel_radius
    grass = [
        read_wheel_log(p, wheel_radius=r) for p in sorted(data.glob("warthog_wheels_grass*.csv"))
    ]
    window_logs = {
        t: read_wheel_log(data / f"windows_warthog_{t}.csv", wheel_radius=r)
        for t in ("asphalt", "gravel")
    }
    if args.speed:
        fit_speed(grass, cfg, args.repeat)
        return
    fit_time(grass, cfg)
    loro(grass, cfg)
    windows_split(window_logs, cfg)
    print("\nPer-terrain comparison (compare --by-terrain):")
    report = compare(
        [grass[0], grass[2], grass[4], *(select_segments(w, 0) for w in window_logs.values())],
        [grass[1], grass[3], *(select_segments(w, 1) for w in window_logs.values())],
        out_dir=args.out,
        by_terrain=True,
        config=cfg,
    )
    print(report.markdown)
    print(f"tables, box plot and parameter files in {args.out}")
    print(f"({time.perf_counter() - started:.0f} s)")


if __name__ == "__main__":
    main()
