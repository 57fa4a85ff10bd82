"""Chen et al. 2023's experiment reproduced on the simulator (issue 4 acceptance).

For each seed: ``terrain-odom simulate --scenario chen2023 --seed S
--frame-format jpg``, ``terrain-odom train --tile-size 32`` on that run's patches
(ground the run does not drive over), then ``terrain-odom run --images ... --groundtruth
...`` once per reset schedule (``--reset-at arrival`` and ``immediate``).
Prints, per seed and schedule: frame accuracy, feature time with and without
the region of interest (and with the KNN vote added), mean model-odometry position error of idd and the
three EKF variants, and ICR re-convergence after each true change; then the
acceptance lines.

Usage::

    python bench/chen2023.py [--seeds 0 1 2] [--work /tmp/chen2023] [--reuse] [--pose-noise XY YAW]

About 2 min per seed on one core (60 s runs, 600 frames of 320x240).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from terrain_odom.cli.main import main as cli

SCHEDULES = ("arrival", "immediate")
TERRAIN = "ekf (terrain + memory)"
NO_TERRAIN = "ekf (no terrain)"


def _prepare(work: Path, seed: int, reuse: bool, pose_noise: list[str] | None = None) -> Path:
    sim = work / f"seed{seed}"
    if not (reuse and (sim / "classifier.npz").is_file()):
        args = ["--out", str(sim), "--scenario", "chen2023", "--seed", str(seed)]
        args += ["--pose-noise", *pose_noise] if pose_noise else []
        assert cli(["simulate", *args, "--frame-format", "jpg"]) == 0
        patches = str(sim / "patches")  # train --out SIM writes SIM/classifier.npz
        train = [
            "train",
            "--images",
            patches,
            "--out",
            str(sim),
            "--jobs",
            "1",
            "--tile-size",
            "32",
        ]
        assert cli(train) == 0
    return sim


def _run(sim: Path, out: Path, schedule: str) -> dict:
    args = ["run", "--images", str(sim), "--wheels", str(sim / "log.csv")]
    args += ["--classifier", str(sim), "--groundtruth", str(sim / "groundtruth.csv")]
    assert cli([*args, "--reset-at", schedule, "--out", str(out), "--overwrite"]) == 0
    return json.loads((out / "report.json").read_text())["groundtruth"]


def _summary(section: dict) -> dict:
    times = section["frames"]["feature_time"]["all"]
    with_knn = section["frames"]["classification_time"]["all"]
    odometry = {k: v["mean_position_error_m"] for k, v in section["odometry"].items()}
    settle = {
        name: [c["settling_s"] for c in changes]
        for name, changes in section["reconvergence"].items()
    }
    return {
        "accuracy_%": 100.0 * section["frames"]["accuracy"]["overall"]["accuracy"],
        "roi_ms": times["roi"]["mean_ms"],
        "full_ms": times["full_frame"]["mean_ms"],
        "roi_speedup": times["speedup"],
        "roi_speedup_with_knn": with_knn["speedup"],
        "position_error_m": odometry,
        "ratio_terrain_to_no_terrain": odometry[TERRAIN] / odometry[NO_TERRAIN],
        "reconvergence_s": settle,
    }


def _fmt(values: list) -> str:
    return ", ".join("never" if v is None else f"{v:.2f}" for v in values)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--work", type=Path, default=Path("/tmp/chen2023"))
    parser.add_argument("--reuse", action="store_true", help="reuse simulated runs and models")
    parser.add_argument(
        "--pose-noise", nargs=2, metavar=("XY_M", "YAW_RAD"), help="simulate --pose-noise"
    )
    args = parser.parse_args()
    rows = []
    for seed in args.seeds:
        sim = _prepare(args.work, seed, args.reuse, args.pose_noise)
        for schedule in SCHEDULES:
            summary = _summary(_run(sim, args.work / f"run{seed}-{schedule}", schedule))
            rows.append((seed, schedule, summary))
            errors = summary["position_error_m"]
            print(
                f"seed {seed} {schedule:9s} frames {summary['accuracy_%']:.1f} % | features "
                f"{summary['roi_ms']:.2f} ms ROI vs {summary['full_ms']:.2f} ms whole "
                f"({summary['roi_speedup']:.2f}x; with KNN "
                f"{summary['roi_speedup_with_knn']:.2f}x) | position error "
                + ", ".join(f"{k} {v:.3f}" for k, v in errors.items())
                + f" | ratio {summary['ratio_terrain_to_no_terrain']:.2f} | re-convergence "
                + "; ".join(f"{k}: {_fmt(v)}" for k, v in summary["reconvergence_s"].items())
            )
    for schedule in SCHEDULES:
        picked = [s for _, sch, s in rows if sch == schedule]
        ratios = [s["ratio_terrain_to_no_terrain"] for s in picked]
        settles = [v for s in picked for v in s["reconvergence_s"][TERRAIN]]
        worst = None if None in settles else max(settles)
        print(
            f"{schedule}: {TERRAIN} / {NO_TERRAIN} position error: mean "
            f"{np.mean(ratios):.2f}, worst {max(ratios):.2f} (target <= 0.50); worst "
            f"re-convergence {_fmt([worst])} s (target <= 2); ROI feature speed-up mean "
            f"{np.mean([s['roi_speedup'] for s in picked]):.2f}x (target >= 4), with the "
            f"KNN vote {np.mean([s['roi_speedup_with_knn'] for s in picked]):.2f}x"
        )


if __name__ == "__main__":
    main()
