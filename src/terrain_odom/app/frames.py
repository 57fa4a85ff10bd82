"""Per-frame terrain classification for the run: decode, region of interest, SFTA + KNN.

:class:`FramePipeline` is the :class:`~terrain_odom.estimation.odometry.FrameObserver`
that :func:`~terrain_odom.estimation.odometry.run_icr_ekf` calls for every
frame in the log's time span. For each frame it decodes the image, places the
region of interest from the current wheel speeds and ICR estimate
(:func:`~terrain_odom.vision.camera.region_of_interest`; the whole frame with
``use_roi=False``), classifies it, and hands one record per frame to
``on_frame`` once the terrain tracker has seen the label. Each label comes
with how far ahead the classified ground is: the distance to the predicted
pose at the region's centre, or with the whole frame to the ground point at
the image centre. (The ground at the region's pixel centre, nearer because
perspective gives near ground more pixels, did worse in ``bench/chen2023.py``
with 32-px tiles voting over the whole box: terrain/no-terrain error 0.45,
0.50, 0.47 against 0.37, 0.51, 0.36.) Only the tiles whose centre is inside
the footprint's projection vote (:func:`~terrain_odom.vision.classifier.tiles_within`).
"""

from __future__ import annotations

import contextlib
import functools
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

import cv2
import numpy as np
from threadpoolctl import threadpool_limits

from terrain_odom.config import RoiConfig
from terrain_odom.errors import InputFileError
from terrain_odom.io.frames import FrameList
from terrain_odom.records import Sighting
from terrain_odom.vision.camera import GroundCamera, crop, region_of_interest
from terrain_odom.vision.classifier import TerrainClassifier, image_features
from terrain_odom.vision.dataset import read_image_rgb

__all__ = ["FRAME_COLUMNS", "FrameRecord", "FramePipeline", "ReplayedFrames", "one_thread"]

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

FULL_FRAME = "full_frame"
"""``roi_status`` of a frame classified whole (``--no-roi``)."""


@contextlib.contextmanager
def one_thread() -> Iterator[None]:
    """Run the block on one thread: OpenMP, BLAS and OpenCV pools limited to 1.

    A frame's KNN query (a few tiles against ~1000 training rows) and its
    OpenCV calls are far too small to share out: scikit-learn's OpenMP
    threads then mostly wait for each other, and on a machine whose cores
    are busy with other processes a 0.6 ms query took 100 ms. The previous
    limits are restored on exit.
    """
    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        with threadpool_limits(limits=1):
            yield
    finally:
        cv2.setNumThreads(threads)


@dataclass
class FrameRecord:
    """What was done with one frame (a row of ``frames.csv``).

    ``label`` is ``""`` and ``confidence``/``box`` are empty when the region
    of interest has no usable box (``roi_status`` ``outside`` or
    ``too_small``); ``ms_features`` is the feature-extraction (SFTA and
    colour) time and ``ms_knn`` the KNN vote's, ``ms_total`` includes
    decoding and the region of interest; ``ahead`` is the distance from the
    robot to the classified ground, m; ``ms_features_full`` and
    ``ms_knn_full`` the same on the whole frame when that is timed for
    comparison.
    """

    t: float
    file: str
    label: str = ""
    confidence: float = float("nan")
    confirmed_label: str = ""
    box: tuple[int, int, int, int] | None = None
    ms_features: float = float("nan")
    ms_total: float = float("nan")
    roi_status: str = ""
    ahead: float = float("nan")
    ms_features_full: float = float("nan")
    ms_knn: float = float("nan")
    ms_knn_full: float = float("nan")

    def row(self) -> dict[str, object]:
        """Return the record as a ``frames.csv`` row."""
        box: tuple[object, ...] = self.box if self.box is not None else ("", "", "", "")
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
    """Classify the frames of a run (a ``FrameObserver``).

    Parameters
    ----------
    frames : FrameList
    classifier : TerrainClassifier
    camera : GroundCamera
        Must match the frames' size (checked on every decoded frame).
    roi : RoiConfig
    use_roi : bool
        False: classify the whole frame.
    on_frame : callable, optional
        Called with the :class:`FrameRecord` of every frame processed.
    names : callable, optional
        Maps a frame's path to the text of its ``file`` cell.
    time_full_frame : bool
        Also time features and KNN on the whole frame (its label is not used), for
        Chen's Table 2 comparison: before the region on even-numbered frames,
        after it on odd ones, so that each meets cold caches equally often.

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
    classifier: TerrainClassifier
    camera: GroundCamera
    roi: RoiConfig
    use_roi: bool = True
    on_frame: Callable[[FrameRecord], None] | None = None
    names: Callable[[object], str] = str
    time_full_frame: bool = False
    problems: list[dict[str, object]] = field(default_factory=list)
    roi_counts: dict[str, int] = field(default_factory=dict)
    ms_total: list[float] = field(default_factory=list)
    _pending: FrameRecord | None = field(default=None, init=False, repr=False)

    @property
    def times(self) -> np.ndarray:
        """Frame times, s."""
        return self.frames.t

    def observe(
        self, index: int, t: float, v_l: float, v_r: float, icr_params: np.ndarray
    ) -> Sighting | None:
        """Classify frame ``index``; None if it is unreadable or has no usable region."""
        started = time.perf_counter()
        path = self.frames.files[index]
        self._pending = None
        image = read_image_rgb(path)
        if image is None:
            problem = "missing" if not path.is_file() else "unreadable (not a decodable image)"
            self.problems.append({"t": t, "file": self.names(path), "problem": problem})
            return None
        height, width = image.shape[:2]
        if self.use_roi and (width, height) != (self.camera.width, self.camera.height):
            raise InputFileError(
                f"{path}: image is {width}x{height} px but the camera configuration says "
                f"{self.camera.width}x{self.camera.height}; fix camera.width/height in --config "
                "(or use --no-roi)"
            )
        record = FrameRecord(t, self.names(path))
        if self.use_roi:
            result = region_of_interest(self.camera, self.roi, v_l, v_r, icr_params)
            record.roi_status = result.status.value
            record.box = result.box
            record.ahead = float(np.hypot(*result.pose[:2]))
            region = footprint = None
            if result.box is not None:  # the footprint's tiles vote, not its bounding box's
                region = crop(image, result)
                footprint = result.image_polygon - np.array(result.box[:2], dtype=float)
        else:
            record.roi_status = FULL_FRAME
            record.box = (0, 0, width, height)
            record.ahead = self._image_centre_ahead
            region, footprint = image, None
        self.roi_counts[record.roi_status] = self.roi_counts.get(record.roi_status, 0) + 1
        # The whole frame is timed before the region on every other frame, so that
        # each gets the cold caches of the first classification equally often.
        whole = self.time_full_frame and self.use_roi and region is not None
        whole_first = whole and index % 2 == 0
        if whole_first:
            record.ms_features_full, record.ms_knn_full = self._time_whole(image)
        if region is not None:
            (record.label, record.confidence), record.ms_features, record.ms_knn = (
                self._classify_timed(region, footprint)
            )
            record.ms_total = 1e3 * (time.perf_counter() - started)
            if whole_first:
                record.ms_total -= record.ms_features_full + record.ms_knn_full
            self.ms_total.append(record.ms_total)
        if whole and not whole_first:
            record.ms_features_full, record.ms_knn_full = self._time_whole(image)
        elif self.time_full_frame and not whole:
            record.ms_features_full, record.ms_knn_full = record.ms_features, record.ms_knn
        self._pending = record
        return Sighting(record.label, record.ahead) if record.label else None

    def _classify_timed(
        self, region: np.ndarray, footprint: np.ndarray | None
    ) -> tuple[tuple[str, float], float, float]:
        """``(label, confidence)``, feature time and KNN time (ms) of a region."""
        started = time.perf_counter()
        features = image_features(region, self.classifier.cfg, footprint)
        extracted = time.perf_counter()
        result = self.classifier.vote(features)
        return result, 1e3 * (extracted - started), 1e3 * (time.perf_counter() - extracted)

    def _time_whole(self, image: np.ndarray) -> tuple[float, float]:
        """Feature and KNN time on the whole frame, ms (its label is not used)."""
        return self._classify_timed(image, None)[1:]

    @functools.cached_property
    def _image_centre_ahead(self) -> float:
        """Distance to the ground at the image centre, m (0 if it is above the horizon)."""
        centre = [(self.camera.width - 1) / 2.0, (self.camera.height - 1) / 2.0]
        ahead = float(np.hypot(*self.camera.backproject([centre])[0]))
        return ahead if np.isfinite(ahead) else 0.0

    def confirmed(self, index: int, label: str) -> None:
        """Record the confirmed terrain after frame ``index`` and emit its record."""
        record, self._pending = self._pending, None
        if record is None:
            return
        record.confirmed_label = label
        if self.on_frame is not None:
            self.on_frame(record)


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

    def observe(
        self, index: int, t: float, v_l: float, v_r: float, icr_params: np.ndarray
    ) -> Sighting | None:
        """Return the recorded sighting of frame ``index``."""
        record = self.records[index]
        return Sighting(record.label, record.ahead) if record.label else None

    def confirmed(self, index: int, label: str) -> None:
        """Ignore the confirmed terrain (nothing is written)."""
