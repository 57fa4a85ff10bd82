"""Cost of ``run --record``: writing ``run.rrd`` against the run it records, measured in one go.

1. Rows: the demo log repeated to at least ``--rows`` rows (times shifted),
   run through the ICR EKF (the baseline), then written as a recording
   (:func:`terrain_odom.reporting.recording.record_run`, into memory).
2. Frames: the quick start's camera run (``sample_images/chen2023``), the
   whole ``run`` without and with ``record=True`` (ROI votes computed again
   per frame, frame files copied in).

Printed: rows or frames, seconds, the ratio to the baseline, and the
recording's size. The figures are those of docs/plots.md, "A recording to
scrub through".

Usage::

    python bench/recording.py [--rows 100000]
"""

from __future__ import annotations

import argparse
import dataclasses
import io
import tempfile
import time
from pathlib import Path

import numpy as np

from terrain_odom.app.run import RunOptions, run
from terrain_odom.config import load_config
from terrain_odom.estimation.odometry import run_odometry
from terrain_odom.estimation.online import OnlineOdometry
from terrain_odom.io import read_wheel_log
from terrain_odom.records import WheelLog
from terrain_odom.reporting.recording import record_run

REPO = Path(__file__).resolve().parents[1]
SAMPLE = REPO / "sample_images" / "chen2023"


def _repeated(log: WheelLog, times: int) -> WheelLog:
    """Return ``log`` repeated ``times`` times, each copy after the previous one."""
    step = float(np.median(np.diff(log.t)))
    span = float(log.t[-1] - log.t[0]) + step
    t = np.concatenate([log.t + k * span for k in range(times)])

    def tile(a: np.ndarray) -> np.ndarray:
        return np.concatenate([a] * times)

    terrain = None if log.terrain is None else tile(log.terrain)
    return dataclasses.replace(log, t=t, v_l=tile(log.v_l), v_r=tile(log.v_r), pose=tile(log.pose),
                               terrain=terrain, segment=tile(log.segment))  # fmt: skip


def rows(n: int) -> None:
    """Time the filter and the recording of at least ``n`` rows."""
    cfg = load_config(REPO / "examples" / "demo.yaml")
    demo = read_wheel_log(REPO / "examples" / "demo_log.csv", wheel_radius=cfg.robot.wheel_radius)
    log = _repeated(demo, -(-n // len(demo)))
    labels = None if log.terrain is None else [str(x) for x in log.terrain]
    started = time.perf_counter()
    result = run_odometry(log, OnlineOdometry(cfg, None), labels=labels)
    filtered = time.perf_counter() - started
    handle = io.BytesIO()
    started = time.perf_counter()
    record_run(handle, log, result, arrow=cfg.robot.track_width)
    recorded = time.perf_counter() - started
    print(f"{len(log)} rows: filter {filtered:.2f} s, recording {recorded:.2f} s "
          f"(x{recorded / filtered:.2f}), {len(handle.getvalue()) / 1e6:.1f} MB")  # fmt: skip


def frames() -> None:
    """Time the quick start's camera run without and with its recording."""
    seconds: dict[bool | None, float] = {}
    with tempfile.TemporaryDirectory() as folder:
        for record in (None, False, True):  # None: a first run, loading every module
            out = Path(folder) / str(record)
            started = time.perf_counter()
            summary = run(
                SAMPLE / "log.csv",
                out,
                RunOptions(images=SAMPLE, progress=False, record=bool(record)),
            )
            seconds[record] = time.perf_counter() - started
        size = (Path(folder) / "True" / "run.rrd").stat().st_size
    frames = summary.report.frames
    n = frames.counts.classified if frames and frames.counts else 0
    print(f"{n} frames: run {seconds[False]:.2f} s, with --record {seconds[True]:.2f} s "
          f"(x{seconds[True] / seconds[False]:.2f}), {size / 1e6:.1f} MB")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=100_000)
    args = parser.parse_args()
    rows(args.rows)
    frames()


if __name__ == "__main__":
    main()
