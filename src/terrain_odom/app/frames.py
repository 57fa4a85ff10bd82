"""Camera frames of a run: decoding, problems, ``frames.csv`` records.

:class:`FramePipeline` is the :class:`~terrain_odom.estimation.odometry.FrameObserver`
that :func:`~terrain_odom.estimation.odometry.run_odometry` calls for every
frame in the log's time span: it decodes the frame file and hands the image
to :meth:`~terrain_odom.estimation.online.OnlineOdometry.frame` (region of
interest, features, vote, tracker:
:class:`~terrain_odom.vision.frame_classifier.FrameClassifier`), then gives
one :class:`FrameRecord` per frame to ``on_frame``.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.estimation.online import OnlineOdometry
from terrain_odom.io.frames import FrameList
from terrain_odom.io.images import decode_image_rgb, read_image_bytes
from terrain_odom.vision.frame_classifier import FrameClassification

__all__ = [
    "FRAME_COLUMNS",
    "FrameRecord",
    "FramePipeline",
    "ReplayedFrames",
    "one_thread",
    "read_frame",
]

FRAME_COLUMNS = (
    "t",
    "file",
    "label",
    "confidence",
    "confirmed_label",
    "roi_x0",
    "roi_y0",
    "roi_x1",
    "roi_y1",
    "ms_features",
    "ms_total",
    "roi_status",
    "ahead_m",
    "ms_features_full",
    "ms_knn",
    "ms_knn_full",
)
"""Columns of ``OUT/frames.csv``."""


@contextlib.contextmanager
def one_thread() -> Iterator[None]:
    """Run the block on one thread: OpenMP, BLAS and OpenCV pools limited to 1.

    A frame's KNN query (a few tiles against ~1000 training rows) and its
    OpenCV calls are far too small to share out: scikit-learn's OpenMP
    threads then mostly wait for each other, and on a machine whose cores
    are busy with other processes a 0.6 ms query took 100 ms. The previous
    limits are restored on exit.
    """
    import cv2  # ~0.1 s: loaded by a camera run only

    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        with threadpool_limits(limits=1):
            yield
    finally:
        cv2.setNumThreads(threads)


def read_frame(path: Path) -> tuple[np.ndarray | None, str]:
    """Decode a frame file to RGB; ``(None, problem)`` if it is missing or unreadable."""
    data, problem = read_image_bytes(path)
    image = None if data is None else decode_image_rgb(data)
    if image is not None:
        return image, ""
    return None, problem or "unreadable (not a decodable image)"


@dataclass
class FrameRecord(FrameClassification):
    """What was done with one frame (a row of ``frames.csv``).

    The fields of :class:`~terrain_odom.vision.frame_classifier.FrameClassification`
    (``ms_total`` here includes decoding), the frame's ``file`` and the
    terrain the tracker had confirmed after its label (``confirmed_label``).
    """

    file: str = ""
    confirmed_label: str = ""

    @classmethod
    def of(cls, frame: FrameClassification, file: str, confirmed_label: str) -> FrameRecord:
        """Return the record of a classified frame."""
        values = {f.name: getattr(frame, f.name) for f in fields(frame)}
        return cls(**values, file=file, confirmed_label=confirmed_label)

    def row(self) -> dict[str, str | float]:
        """Return the record as a ``frames.csv`` row."""
        box: tuple[str | float, ...] = self.box if self.box is not None else ("", "", "", "")
        return {
            "t": self.t,
            "file": self.file,
            "label": self.label,
            "confidence": self.confidence,
            "confirmed_label": self.confirmed_label,
            **dict(zip(("roi_x0", "roi_y0", "roi_x1", "roi_y1"), box, strict=True)),
            "ms_features": self.ms_features,
            "ms_total": self.ms_total,
            "roi_status": self.roi_status,
            "ahead_m": self.ahead,
            "ms_features_full": self.ms_features_full,
            "ms_knn": self.ms_knn,
            "ms_knn_full": self.ms_knn_full,
        }


@dataclass
class FramePipeline:
    """Decode the frames of a run and classify them (a ``FrameObserver``).

    Parameters
    ----------
    frames : FrameList
    on_frame : callable, optional
        Called with the :class:`FrameRecord` of every frame processed.
    names : callable, optional
        Maps a frame's path to the text of its ``file`` cell.

    Attributes
    ----------
    problems : list of dict
        Missing or unreadable frames (``t, file, problem``), skipped.
    roi_counts : dict of str to int
        Frames per ``roi_status``.
    ms_total : list of float
        Time spent on each classified frame, ms.
    """

    frames: FrameList
    on_frame: Callable[[FrameRecord], None] | None = None
    names: Callable[[Path], str] = str
    problems: list[dict[str, object]] = field(default_factory=list)
    roi_counts: dict[str, int] = field(default_factory=dict)
    ms_total: list[float] = field(default_factory=list)

    @property
    def times(self) -> np.ndarray:
        """Frame times, s."""
        return self.frames.t

    def feed(self, index: int, odometry: OnlineOdometry) -> None:
        """Decode frame ``index`` and give it to ``odometry``; record it (or its problem).

        Raises
        ------
        InputFileError
            The frame's size is not the configured camera's.
        """
        started = time.perf_counter()
        t, path = float(self.frames.t[index]), self.frames.files[index]
        image, problem = read_frame(path)
        if image is None:
            self.problems.append({"t": t, "file": self.names(path), "problem": problem})
            return
        decoding = 1e3 * (time.perf_counter() - started)
        try:
            frame = odometry.frame(t, image)
        except ConfigError as err:
            raise InputFileError(f"{path}: {err}; fix it in --config (or use --no-roi)") from None
        self.roi_counts[frame.roi_status] = self.roi_counts.get(frame.roi_status, 0) + 1
        record = FrameRecord.of(frame, self.names(path), odometry.seen_terrain)
        if np.isfinite(record.ms_total):  # classified
            record.ms_total += decoding
            self.ms_total.append(record.ms_total)
        if self.on_frame is not None:
            self.on_frame(record)

    def check_used(self, source: str | Path) -> None:
        """Refuse a camera run none of whose fed frames was classified, naming why.

        Frames outside the wheel log's span are not fed (and not counted).

        Raises
        ------
        InputFileError
            Frames were fed, none classified: the counts of each cause.
        """
        fed = len(self.problems) + sum(self.roi_counts.values())
        if self.ms_total or not fed:
            return
        causes = [f"{n} {status}" for status, n in sorted(self.roi_counts.items())]
        if self.problems:
            causes.append(f"{len(self.problems)} missing or unreadable")
        hint = (
            "; the region of interest lies outside the frames: check camera (mount_pitch, "
            "mount_height, fx, cx, cy) in --config, or run with --no-roi"
            if self.roi_counts.get("outside") or self.roi_counts.get("too_small")
            else ""
        )
        raise InputFileError(
            f"{source}: none of the {fed} frames in the log's span was classified "
            f"(region of interest: {', '.join(causes)}){hint}"
        )


@dataclass
class ReplayedFrames:
    """A frame observer replaying the labels of recorded frames (no image is read).

    Runs filter variants on the labels a :class:`FramePipeline` produced, e.g.
    with and without terrain memory. The regions a variant would have
    classified can differ slightly, as they follow its own ICR estimate.

    Parameters
    ----------
    records : list of FrameRecord
        Frames as recorded (with their ``label`` and ``ahead``).
    """

    records: list[FrameRecord]

    @property
    def times(self) -> np.ndarray:
        """Frame times, s."""
        return np.array([r.t for r in self.records], dtype=float)

    def feed(self, index: int, odometry: OnlineOdometry) -> None:
        """Give the recorded sighting of frame ``index`` to ``odometry``."""
        record = self.records[index]
        if record.sighting is not None:
            odometry.sighting(record.t, record.sighting)
