"""Speed of the whole ``terrain-odom run`` on 640x480 frames, on one core (issues 4 and 26).

Simulates the ``chen2023`` scenario with its camera doubled in resolution
(640x480, fx = fy = 400 px, same mounting, so the same ground at twice the
pixels), trains the classifier (the default features) on that run's patches
with tiles of about 128 px (a 640x480 region of interest covers ~28 % of
the frame, ~86 000 px: about 5 tiles, where 64-px tiles would make ~21 and
take twice as long), then times on one core, pinned, with one thread, each
figure best of ``--repeat`` runs, the runs of the four alternating:

- **decode**: ``cv2.imread`` of every frame (the pure decoding baseline);
- **run**: the Python API behind ``terrain-odom run --images ... --wheels
  ... --no-plots`` (:func:`terrain_odom.app.run.run`): reading the log and
  frames list, decoding, region of interest, features + KNN, terrain
  tracking, the ICR EKF over every wheel row and pose measurement, streaming
  ``trajectory.csv`` and ``frames.csv``, ``report.json`` and ``report.md``
  (no ground truth, so no whole-frame timing). Its frames per second are
  the figure of the target (>= 250);
- **run with plots**: the same drawing its three plots (the command's
  default), a fixed cost per run whatever its length: printed as seconds
  and as the frame rate of this 60-s run;
- **run without frames**: the same over the wheel log alone, ``--no-plots``
  (the EKF's share).

Prints the frame rates and times per frame as ratios of the pure decoding
time, the mean per-frame times the run itself recorded in ``frames.csv``,
and the machine's load average before and after (other jobs slow all of
them); then, untimed, the frame accuracy of one more run scored with
``--groundtruth``. With ``--parts``, where a frame's time goes: the run's
frame work replayed step by step on the same frames (with the speeds of the
log and the ICRs of the run's trajectory), CPU time per frame of each step,
best of ``--repeat`` passes.

Usage::

    python bench/run.py [--work /tmp/bench_run] [--duration 60] [--repeat 3] [--reuse] [--parts]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np

from terrain_odom.app.frames import one_thread
from terrain_odom.app.inputs import TerrainSource
from terrain_odom.app.run import RunOptions, run
from terrain_odom.cli.main import main as cli
from terrain_odom.config import load_config
from terrain_odom.io.classifier_file import load_classifier
from terrain_odom.io.frames import read_frames
from terrain_odom.io.images import decode_image_rgb
from terrain_odom.io.trajectory import read_trajectory_csv
from terrain_odom.io.wheel_log import read_wheel_log
from terrain_odom.vision import features
from terrain_odom.vision.camera import GroundCamera, crop, region_of_interest
from terrain_odom.vision.sfta import to_grey

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


def alternately(
    repeat: int, timed: dict[str, Callable[[], None]]
) -> tuple[dict[str, float], dict[str, float]]:
    """Smallest wall and CPU times of ``repeat`` calls of each function, s, the functions taking turns.

    On a machine whose cores other jobs share, the wall time includes the
    waits for a core; the CPU time (``time.process_time``) does not.
    """
    wall = dict.fromkeys(timed, float("inf"))
    cpu = dict.fromkeys(timed, float("inf"))
    for _ in range(repeat):
        for name, fn in timed.items():
            started, started_cpu = time.perf_counter(), time.process_time()
            fn()
            cpu[name] = min(cpu[name], time.process_time() - started_cpu)
            wall[name] = min(wall[name], time.perf_counter() - started)
    return wall, cpu


def _print_times(wall: dict[str, float], cpu: dict[str, float], n_frames: int) -> None:
    """Print the times per frame, frame rates and ratios to decoding, wall [CPU]."""

    def figures(name: str) -> str:
        ms = [1e3 * times[name] / n_frames for times in (wall, cpu)]
        rate = [n_frames / times[name] for times in (wall, cpu)]
        ratio = [times[name] / times["decode"] for times in (wall, cpu)]
        return (
            f"{ms[0]:6.2f} [{ms[1]:5.2f}] ms/frame = {rate[0]:6.1f} [{rate[1]:6.1f}] frames/s"
            f" = {ratio[0]:.2f} [{ratio[1]:.2f}] x decode"
        )

    print(f"decode only        {figures('decode')}")
    print(f"run without frames {figures('wheels')} (EKF over the wheel log)")
    print(f"whole run          {figures('run')} (--no-plots; target >= 250 frames/s)")
    plots = [wall["plots"] - wall["run"], cpu["plots"] - cpu["run"]]
    print(f"with its plots     {figures('plots')} (plots {plots[0]:.2f} [{plots[1]:.2f}] s a run)")


PARTS = ("read", "decode", "roi", "tiles", "grey", "sfta", "lbp", "lab", "vote")
"""The steps of a frame's classification that ``--parts`` times."""


def frame_parts(sim: Path, out: Path, repeat: int) -> dict[str, float]:
    """CPU time per frame of each step of the frames' classification, s (best of ``repeat``).

    The steps of ``terrain-odom run``'s frame work with the default
    features (SFTA, LBP, CIELAB), called one by one on the run's frames:
    the region of interest at the log's held speeds and the ICRs the run
    estimated (``out``'s ``trajectory.csv``) at each frame's time.
    """
    config = load_config(sim / "config.yaml")
    camera, classifier = GroundCamera(config.camera), load_classifier(sim / MODEL)
    frames, log = read_frames(sim), read_wheel_log(sim / "log.csv")
    states = read_trajectory_csv(out / "trajectory.csv")
    row = np.clip(np.searchsorted(log.t, frames.t, side="right") - 1, 0, len(log) - 1)
    icrs = np.column_stack([states[name] for name in ("y_l", "y_r", "x_icr")])[row]
    best = dict.fromkeys(PARTS, float("inf"))
    for _ in range(repeat):
        spent = dict.fromkeys(PARTS, 0.0)
        for i, path in enumerate(frames.files):
            step = _Steps(spent)
            data = path.read_bytes()
            step("read")
            image = decode_image_rgb(data)
            step("decode")
            roi = region_of_interest(camera, config.roi, log.v_l[row[i]], log.v_r[row[i]], icrs[i])
            step("roi")
            if roi.box is None:
                continue
            region = crop(image, roi)
            height, width = region.shape[:2]
            footprint = roi.image_polygon - np.array(roi.box[:2], dtype=float)
            boxes = features.tile_boxes(height, width, classifier.config)
            boxes = boxes[features.tiles_within(height, width, classifier.config, footprint)]
            tiles = [(slice(y0, y1), slice(x0, x1)) for x0, y0, x1, y1 in boxes.tolist()]
            step("tiles")
            grey = to_grey(region)
            step("grey")
            sfta = np.stack([features._sfta(grey[t], grey[t], classifier.config) for t in tiles])
            step("sfta")
            lbp = features.lbp_histograms(grey, boxes)
            step("lbp")
            lab = np.stack([features.colour_statistics(region[t], "lab") for t in tiles])
            step("lab")
            classifier.vote(np.hstack([sfta, lbp, lab]))
            step("vote")
        best = {name: min(best[name], spent[name] / len(frames.files)) for name in PARTS}
    return best


class _Steps:
    """Adds the CPU time since the previous call to the named step."""

    def __init__(self, spent: dict[str, float]) -> None:
        self.spent = spent
        self.started = time.process_time()

    def __call__(self, name: str) -> None:
        now = time.process_time()
        self.spent[name] += now - self.started
        self.started = now


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, default=Path("/tmp/bench_run"))
    parser.add_argument("--duration", type=float, default=60.0, help="simulated seconds")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--reuse", action="store_true", help="reuse the simulated run and model")
    parser.add_argument("--parts", action="store_true", help="also time each step of a frame")
    args = parser.parse_args()
    sim = prepare(args.work, args.duration, args.reuse)
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    files = read_frames(sim).files
    n_frames = len(files)
    print(f"load average before: {os.getloadavg()}; one core, one thread")

    def decode() -> None:
        for path in files:
            assert cv2.imread(str(path), cv2.IMREAD_COLOR) is not None

    def camera_run(out: str, plots: bool) -> Callable[[], None]:
        def timed() -> None:
            run(
                sim / "log.csv",
                args.work / out,
                RunOptions(
                    images=sim,
                    classifier_path=sim / MODEL,
                    progress=False,
                    overwrite=True,
                    plots=plots,
                ),
            )

        return timed

    def wheels_only() -> None:
        run(
            sim / "log.csv",
            args.work / "out_wheels",
            RunOptions(terrain=TerrainSource.NONE, progress=False, overwrite=True, plots=False),
        )

    timed = {
        "decode": decode,
        "run": camera_run("out", plots=False),
        "plots": camera_run("out_plots", plots=True),
        "wheels": wheels_only,
    }
    with one_thread():
        wall, cpu = alternately(args.repeat, timed)
    frames = np.genfromtxt(args.work / "out" / "frames.csv", delimiter=",", names=True)
    height, width = cv2.imread(str(files[0])).shape[:2]
    print(f"{n_frames} frames of {width}x{height}, best of {args.repeat}: wall time [CPU time]")
    _print_times(wall, cpu, n_frames)
    print(
        f"in the run: features {np.nanmean(frames['ms_features']):.2f} ms + KNN "
        f"{np.nanmean(frames['ms_knn']):.2f} ms mean, frame total "
        f"(decode + ROI + features + KNN) {np.nanmean(frames['ms_total']):.2f} ms mean"
    )
    if args.parts:
        with one_thread():
            parts = frame_parts(sim, args.work / "out", args.repeat)
        listed = ", ".join(f"{name} {1e3 * parts[name]:.2f}" for name in PARTS)
        print(
            f"a frame's steps replayed, CPU ms/frame: {listed}; sum {1e3 * sum(parts.values()):.2f}"
        )
    print(f"load average after: {os.getloadavg()}")
    scored = args.work / "out_scored"
    run(
        sim / "log.csv",
        scored,
        RunOptions(
            images=sim,
            classifier_path=sim / MODEL,
            groundtruth=sim / "groundtruth.csv",
            overwrite=True,
        ),
    )
    accuracy = json.loads((scored / "report.json").read_text())["groundtruth"]["frames"]
    overall = accuracy["accuracy"]["overall"]
    print(f"frames right (untimed run with --groundtruth): {100 * overall['accuracy']:.1f} %")


if __name__ == "__main__":
    main()
