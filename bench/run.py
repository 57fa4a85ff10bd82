"""Speed of the whole ``terrain-odom run`` on 640x480 frames, on one core (issue 4 acceptance).

Simulates the ``chen2023`` scenario with its camera doubled in resolution
(640x480, fx = fy = 400 px, same mounting, so the same ground at twice the
pixels), trains the classifier on that run's patches with tiles of about
128 px (a 640x480 region of interest covers ~28 % of the frame, ~86 000 px:
about 5 tiles, where 64-px tiles would make ~21 and take twice as long),
then times on one core, pinned, with one thread:

- **decode**: ``cv2.imread`` of every frame (the pure decoding baseline);
- **run**: the Python API behind ``terrain-odom run --images ... --wheels ...``
  (:func:`terrain_odom.app.run.run`): reading the log and frames list,
  decoding, region of interest, SFTA + KNN, terrain tracking, the ICR EKF
  over every wheel row and pose measurement, streaming ``trajectory.csv`` and
  ``frames.csv``, ``report.json`` and ``report.md`` (no ground truth, so no
  whole-frame timing and no plots);
- **run without frames**: the same over the wheel log alone (the EKF share).

Prints frames per second of the whole run (target >= 100) and its time per
frame as a ratio of the pure decoding time, best of ``--repeat`` runs each,
and the machine's load average before and after (other jobs slow all three);
then, untimed, the frame accuracy of one more run scored with ``--groundtruth``.

Usage::

    python bench/run.py [--work /tmp/bench_run] [--duration 60] [--repeat 3] [--reuse]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import cv2
import numpy as np

from terrain_odom.app.frames import one_thread
from terrain_odom.app.run import TerrainSource, run
from terrain_odom.cli.main import main as cli
from terrain_odom.io.frames import read_frames

CAMERA_640 = """\
robot:
  wheel_radius: 0.1
  track_width: 0.5
camera:
  width: 640
  height: 480
  fx: 400.0
  fy: 400.0
  cx: 319.5
  cy: 239.5
  mount_x: 0.3
  mount_y: 0.0
  mount_height: 1.0
  mount_pitch: 1.0471975511965976
"""


TILE_SIZE = 128
MODEL = f"model_tiles{TILE_SIZE}/classifier.npz"  # train --out model_tiles128


def prepare(work: Path, duration: float, reuse: bool) -> Path:
    """Simulate the 640x480 run and train its model (unless reused); return the run folder."""
    sim = work / "sim640"
    if reuse and (sim / MODEL).is_file():
        return sim
    work.mkdir(parents=True, exist_ok=True)
    camera = work / "camera640.yaml"  # robot as the scenario, camera x2
    camera.write_text(CAMERA_640, encoding="utf-8")
    args = ["simulate", "--out", str(sim), "--scenario", "chen2023", "--seed", "0"]
    args += ["--duration", str(duration), "--frame-format", "jpg", "--config", str(camera)]
    assert cli(args) == 0
    train = ["train", "--images", str(sim / "patches"), "--out", str((sim / MODEL).parent)]
    assert cli([*train, "--tile-size", str(TILE_SIZE), "--jobs", "1"]) == 0
    return sim


def best_of(repeat: int, fn) -> float:
    """Smallest wall time of ``repeat`` calls of ``fn``, s."""
    times = []
    for _ in range(repeat):
        started = time.perf_counter()
        fn()
        times.append(time.perf_counter() - started)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, default=Path("/tmp/bench_run"))
    parser.add_argument("--duration", type=float, default=60.0, help="simulated seconds")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--reuse", action="store_true", help="reuse the simulated run and model")
    args = parser.parse_args()
    sim = prepare(args.work, args.duration, args.reuse)
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    files = read_frames(sim).files
    n_frames = len(files)
    print(f"load average before: {os.getloadavg()}; one core, one thread")

    def decode() -> None:
        for path in files:
            assert cv2.imread(str(path), cv2.IMREAD_COLOR) is not None

    def full_run() -> None:
        run(
            sim / "log.csv",
            args.work / "out",
            images=sim,
            model=sim / MODEL,
            progress=False,
            overwrite=True,
        )

    def wheels_only() -> None:
        run(
            sim / "log.csv",
            args.work / "out_wheels",
            terrain=TerrainSource.NONE,
            progress=False,
            overwrite=True,
        )

    with one_thread():
        t_decode = best_of(args.repeat, decode)
        t_run = best_of(args.repeat, full_run)
        t_wheels = best_of(args.repeat, wheels_only)
    frames = np.genfromtxt(args.work / "out" / "frames.csv", delimiter=",", names=True)
    height, width = cv2.imread(str(files[0])).shape[:2]
    per = 1e3 / n_frames
    print(f"{n_frames} frames of {width}x{height}, best of {args.repeat}")
    print(f"decode only        {t_decode * per:6.2f} ms/frame")
    print(f"run without frames {t_wheels * per:6.2f} ms/frame (EKF over the wheel log)")
    print(
        f"whole run          {t_run * per:6.2f} ms/frame = {n_frames / t_run:6.1f} frames/s "
        f"(target >= 100) = {t_run / t_decode:.2f} x decode"
    )
    print(
        f"in the run: features {np.nanmean(frames['ms_features']):.2f} ms + KNN "
        f"{np.nanmean(frames['ms_knn']):.2f} ms mean, frame total "
        f"(decode + ROI + features) {np.nanmean(frames['ms_total']):.2f} ms mean"
    )
    print(f"load average after: {os.getloadavg()}")
    scored = args.work / "out_scored"
    run(
        sim / "log.csv",
        scored,
        images=sim,
        model=sim / MODEL,
        groundtruth=sim / "groundtruth.csv",
        overwrite=True,
    )
    accuracy = json.loads((scored / "report.json").read_text())["groundtruth"]["frames"]
    overall = accuracy["accuracy"]["overall"]
    print(f"frames right (untimed run with --groundtruth): {100 * overall['accuracy']:.1f} %")


if __name__ == "__main__":
    main()
