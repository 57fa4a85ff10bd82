"""Offline priors in the online ICR EKF (``terrain-odom run --priors``).

Prints every figure of docs/results/identification.md ("From offline to online"). The priors are
always fitted on other data than the log they are scored on:

1. simulator: ``icr-slip`` fitted per terrain (``terrain-odom fit
   --by-terrain``) on the ``mixed`` scenario (seed 1: another map, another
   driver), scored on ``chen2023`` seeds 2-4 (grass -> gravel -> grass)
   against ground truth as ``run --groundtruth`` does: ICR re-convergence
   after each true change and mean end position error over 2-m windows, for
   the filter with terrain resets, without and with terrain memory;
2. real (``stitched_grass_to_asphalt.csv``, config/warthog.yaml): grass fitted
   on the four other grass runs, asphalt on the other asphalt recording
   (``windows_warthog_asphalt.csv``, not the asphalt run of the log).
   Model-odometry error
   (median m/m and deg/m, mean end position error over 2-m windows) of the
   windows that start while the robot drives (it stands still ~40 s at the
   start and ~51 s after the switch; every pose measurement then starts a
   window over the same first 2 m of driving).

Usage::

    python bench/priors.py [--data ../shared/data/drive] [--work /tmp/priors-bench]

Takes about two minutes on one core.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from terrain_odom.app.fit import fit
from terrain_odom.app.groundtruth import groundtruth_section
from terrain_odom.app.simulate import write_simulation
from terrain_odom.config import Config, load_config
from terrain_odom.estimation import IcrPriors
from terrain_odom.estimation.odometry import run_icr_ekf
from terrain_odom.evaluation import icr_twist_from_rows, spatial_windows, window_errors
from terrain_odom.fitting.params import icr_priors
from terrain_odom.io import read_wheel_log
from terrain_odom.io.groundtruth import read_groundtruth
from terrain_odom.records import WheelLog
from terrain_odom.sim import get_scenario, simulate

REPO = Path(__file__).resolve().parents[1]
VARIANTS = ("ekf (terrain)", "ekf (terrain + memory)")


def fitted_priors(logs: list[WheelLog], cfg: Config) -> IcrPriors:
    """``icr-slip`` per terrain, fitted as ``terrain-odom fit --by-terrain`` does."""
    params = fit(logs, "icr-slip", by_terrain=True, config=cfg).params
    for label, ps in params.sets.items():
        values = ", ".join(f"{k}={v:.3f}" for k, v in ps.params.items())
        print(f"  prior {label:<8} {values}  ({ps.fit['segments']:.0f} segments)")
    return icr_priors(params)


def simulated(work: Path, scenario: str, seed: int) -> Path:
    """Folder of a simulated run without images (made once)."""
    out = work / f"{scenario}_{seed}"
    if not (out / "groundtruth.csv").is_file():
        write_simulation(simulate(get_scenario(scenario), seed), out, frames=False, patches=False)
    return out


def simulator(work: Path) -> None:
    cfg = load_config()
    print("Simulator: priors fitted on scenario 'mixed', seed 1")
    train = read_wheel_log(simulated(work, "mixed", 1) / "log.csv")
    priors = fitted_priors([train], cfg)
    print(f"\n  {'chen2023 seed / filter':<36}{'re-convergence (s)':>28}  mean position error (m)")
    for seed in (2, 3, 4):
        run = simulated(work, "chen2023", seed)
        log = read_wheel_log(run / "log.csv")
        gt = read_groundtruth(run / "groundtruth.csv")
        for name, given in (("without priors", None), ("with priors", priors)):
            section = groundtruth_section(log, cfg, gt, labels=log.terrain, priors=given).section
            for variant in VARIANTS:
                settle = [c.settling_s for c in section.reconvergence[variant]]
                text = ", ".join("-" if s is None else f"{s:.2f}" for s in settle)
                error = section.odometry[variant].mean_position_error_m
                print(f"  {seed}  {variant:<24} {name:<15} {text:>18}  {error:.4f}")


def first_motion(log: WheelLog, t_from: float) -> float:
    """Return the time of the first row from ``t_from`` with the tracks moving, s."""
    moving = (np.abs(log.v_l) + np.abs(log.v_r) > 0.05) & (log.t >= t_from)
    return float(log.t[np.flatnonzero(moving)[0]])


def real(data: Path) -> None:
    cfg = load_config(REPO / "config" / "warthog.yaml")
    r = cfg.robot.wheel_radius
    log = read_wheel_log(data / "stitched_grass_to_asphalt.csv", wheel_radius=r)
    switch = float(log.t[np.flatnonzero(log.terrain != log.terrain[0])[0]])
    t_grass, t_asphalt = first_motion(log, 0.0), first_motion(log, switch)
    windows = spatial_windows(log)
    start = log.t[windows.start]
    on_grass, on_asphalt = (start >= t_grass) & (start < switch), start >= t_asphalt
    scored = {"grass": on_grass, "asphalt": on_asphalt, "both": on_grass | on_asphalt}
    print(f"\nReal: stitched grass -> asphalt (switch at {switch:.1f} s), config/warthog.yaml")
    train = [
        read_wheel_log(p, wheel_radius=r)
        for p in sorted(data.glob("warthog_wheels_grass*.csv"))
        if "14h4s53" not in p.name  # the grass part of the stitched log
    ]
    train.append(read_wheel_log(data / "windows_warthog_asphalt.csv", wheel_radius=r))
    priors = fitted_priors(train, cfg)
    runs = {
        "without priors": run_icr_ekf(log, cfg, labels=log.terrain),
        "with priors": run_icr_ekf(log, cfg, labels=log.terrain, priors=priors),
    }
    print(
        f"\n  windows starting while driving: {', '.join(f'{k} {m.sum()}' for k, m in scored.items())}"
        "\n  median m/m, median deg/m, mean end position error m"
    )
    for name, result in runs.items():
        icr = [result.states[:, result.names.index(n)] for n in ("y_l", "y_r", "x_icr", "alpha")]
        errors = window_errors(log, windows, icr_twist_from_rows(windows, *icr))
        cells = "  ".join(
            f"{k}: {np.median(errors.translation_per_m[m]):.4f} "
            f"{np.median(errors.rotation_per_m[m]):.3f} {errors.translation[m].mean():.3f}"
            for k, m in scored.items()
        )
        print(f"  {name:<15} {cells}")
        print(
            f"  {'':<15} ICRs after the switch "
            f"{np.round(result.states[np.searchsorted(log.t, result.changes[0].t), 3:], 3)}, "
            f"at the end {np.round(result.states[-1, 3:], 3)}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--data", default=str(REPO.parent / "shared" / "data" / "drive"))
    parser.add_argument("--work", default="/tmp/priors-bench", help="simulated runs go here")
    args = parser.parse_args()
    started = time.perf_counter()
    simulator(Path(args.work))
    real(Path(args.data))
    print(f"\n({time.perf_counter() - started:.0f} s)")


if __name__ == "__main__":
    main()
