"""Camera frames classified on a thread of their own, off the wheel messages' path."""

from __future__ import annotations

import queue
import threading
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from terrain_odom.app.frames import one_thread
from terrain_odom.io.bag.frames import frame_rgb
from terrain_odom.io.bag.reader import BagMessage

if TYPE_CHECKING:
    from terrain_odom.vision.frame_classifier import FrameClassification, FrameClassifier

__all__ = ["MAX_PENDING_FRAMES", "FrameJob", "FrameWorker"]

MAX_PENDING_FRAMES = 3
"""Frames waiting for the classifier beyond which a new one is skipped (counted)."""


@dataclass
class FrameJob:
    """A frame released in time order, with the state it is classified in."""

    t: float
    message: BagMessage  # an Image or CompressedImage, decoded by the worker
    speeds: tuple[float, float]
    params: np.ndarray
    odometer: float


class FrameWorker:
    """Classify frames on a thread of their own; results come back in order."""

    def __init__(self, classifier: FrameClassifier) -> None:
        self.classifier = classifier
        self.todo: queue.Queue[FrameJob | None] = queue.Queue()
        self.done: queue.Queue[tuple[FrameJob, FrameClassification | Exception]] = queue.Queue()
        self.pending = 0
        self.thread = threading.Thread(target=self._loop, name="terrain-odom-frames", daemon=True)
        self.thread.start()

    def _loop(self) -> None:
        with one_thread():  # a frame's small KNN query and OpenCV calls: no thread pools
            self._classify_all()

    def _classify_all(self) -> None:
        while (frame := self.todo.get()) is not None:
            try:
                msg = frame.message
                image = frame_rgb(msg.msg, msg.msgtype, f"--image-topic {msg.topic}")
                result: FrameClassification | Exception = self.classifier.classify(
                    frame.t, image, *frame.speeds, frame.params
                )
            except Exception as exc:  # a frame the classifier refuses: counted, not fatal
                result = exc
            self.done.put((frame, result))

    def submit(self, frame: FrameJob) -> None:
        """Queue a frame for classification (counted in :attr:`pending`)."""
        self.pending += 1
        self.todo.put(frame)

    def results(self, wait: bool) -> list[tuple[FrameJob, FrameClassification | Exception]]:
        """Return the classifications done (all of them, waiting, with ``wait``)."""
        out = []
        while self.pending:
            try:
                item = self.done.get(block=wait)
            except queue.Empty:
                break
            self.pending -= 1
            out.append(item)
        return out

    def stop(self) -> None:
        """Let the thread finish the frames queued, then end it (waiting up to 5 s)."""
        self.todo.put(None)
        self.thread.join(timeout=5.0)
