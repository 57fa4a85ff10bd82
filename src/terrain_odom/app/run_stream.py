"""A run's stream: the log through the filter, the trajectory and frames written as they come.

:func:`stream_log` is the loop of :func:`terrain_odom.app.run.run`: rows in
blocks through :func:`~terrain_odom.estimation.odometry.run_odometry`, each
block written to ``trajectory.csv`` and ``trajectory.tum``, each classified
frame to ``frames.csv``; if anything stops it, ``report.json`` says so.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from tqdm import tqdm

from terrain_odom.app.frames import FRAME_COLUMNS, FramePipeline, FrameRecord, one_thread
from terrain_odom.app.run_folder import FRAMES_CSV, TRAJECTORY_CSV, TRAJECTORY_TUM, mark_interrupted
from terrain_odom.estimation.odometry import OdometryBlock, OdometryResult, run_odometry
from terrain_odom.estimation.online import OnlineOdometry
from terrain_odom.io import TrajectoryWriter
from terrain_odom.io.trajectory import TrajectoryBlocks, TumWriter, trajectory_columns
from terrain_odom.records import WheelLog
from terrain_odom.reporting.run_report import FrameCounts, FramesReport

if TYPE_CHECKING:
    from terrain_odom.io.frames import FrameList

__all__ = ["stream_log", "frames_report"]


def stream_log(
    log: WheelLog,
    odometry: OnlineOdometry,
    out: Path,
    *,
    labels: np.ndarray | None,
    frames: FrameList | None,
    images: Path | None,
    progress: bool | None,
    read: dict[str, str | None],
    keep: int,
    also: Callable[[OdometryBlock], None] = lambda block: None,
) -> tuple[OdometryResult, FramePipeline | None, list[FrameRecord], float]:
    """Stream ``log`` through ``odometry``, writing ``trajectory.csv`` (and ``frames.csv``).

    ``labels``: the log's terrain labels the filter observes; ``frames``
    (in the folder ``images``): the camera frames it classifies; a progress
    bar when ``progress`` (None: on a terminal). ``also`` sees every block of
    rows too (the outage guard keeps states from it).

    The result keeps every ``keep``-th row (:func:`run_odometry`). Returns
    it, the frames' pipeline and records, and the mean ``x_icr`` over the
    second half of the rows (all of them). If anything stops the stream,
    ``report.json`` says the run was interrupted, with the rows written and
    the files ``read``.
    """
    names = odometry.names
    records: list[FrameRecord] = []
    bar = tqdm(total=len(log), unit="row", disable=None if progress is None else not progress)
    with contextlib.ExitStack() as stack:
        writer = stack.enter_context(
            TrajectoryWriter(out / TRAJECTORY_CSV, trajectory_columns(names))
        )
        tum = stack.enter_context(TumWriter(out / TRAJECTORY_TUM))  # in place when complete
        stack.enter_context(bar)
        pipeline = None
        if frames is not None and images is not None:
            stack.enter_context(one_thread())  # camera-rate work on one core (see one_thread)
            frame_writer = stack.enter_context(TrajectoryWriter(out / FRAMES_CSV, FRAME_COLUMNS))

            def on_frame(record: FrameRecord) -> None:
                frame_writer.write(record.row())
                records.append(record)

            root = images
            pipeline = FramePipeline(
                frames,
                on_frame=on_frame,
                names=lambda path: _relative(path, root),
            )

        blocks = TrajectoryBlocks(writer, names, tum)
        x_icr = _SecondHalf(len(log), names.index("x_icr"))

        def on_block(block: OdometryBlock) -> None:
            blocks.write(block.t, block.states, block.stds, block.terrain)
            x_icr.add(block)
            also(block)
            bar.update(block.t.size)

        try:
            result = run_odometry(
                log, odometry, labels=labels, on_block=on_block, frames=pipeline, keep=keep
            )
        except BaseException as exc:
            tum.discard()  # no TUM file of an incomplete run
            with contextlib.suppress(OSError):  # a full disk: the rows are cut to whole ones
                stack.close()  # flush the rows streamed so far before saying how many
            mark_interrupted(out, read, writer.rows_written, exc)
            raise
    return result, pipeline, records, x_icr.mean


@dataclass
class _SecondHalf:
    """Mean of one state over the second half of a run's rows, from its blocks."""

    n_rows: int
    column: int
    total: float = 0.0
    count: int = 0

    def add(self, block: OdometryBlock) -> None:
        first = max(self.n_rows // 2 - block.start, 0)
        values = block.states[first:, self.column]
        self.total += float(values.sum())
        self.count += values.size

    @property
    def mean(self) -> float:
        """The mean (0 before any row)."""
        return self.total / self.count if self.count else 0.0


def _relative(path: Path, root: Path) -> str:
    try:
        return path.relative_to(root).as_posix()
    except ValueError:
        return str(path)


def frames_report(
    result: OdometryResult, pipeline: FramePipeline | None, use_roi: bool
) -> FramesReport:
    """Return the ``frames`` section of a run with images (its frames not read: ``--no-terrain``)."""
    if pipeline is None:
        return FramesReport("skipped (--no-terrain: frames not read)")
    counts = FrameCounts(
        len(pipeline.frames),
        len(pipeline.ms_total),
        result.frames_before,
        result.frames_after,
        tuple(f"{p['file']} ({p['problem']})" for p in pipeline.problems),
    )
    ms = np.asarray(pipeline.ms_total)
    unusable = sum(
        n for status, n in pipeline.roi_counts.items() if status in ("outside", "too_small")
    )
    return FramesReport(
        classification="region of interest" if use_roi else "whole frame (--no-roi)",
        counts=counts,
        unusable=unusable,
        roi_status=dict(pipeline.roi_counts),
        ms_mean=float(ms.mean()) if ms.size else None,
        ms_max=float(ms.max()) if ms.size else None,
        problems=pipeline.problems,
    )
