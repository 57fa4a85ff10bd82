"""Feature extraction in this process (``--jobs 1``) runs OpenCV on one thread, as the workers do."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from terrain_odom.config.classifier import ClassifierConfig
from terrain_odom.io.images import read_image_rgb, scan_image_folder
from terrain_odom.vision.dataset import extract_feature_sets


def _folder(root: Path) -> Path:
    rng = np.random.default_rng(0)
    for label in ("grass", "gravel"):
        (root / label).mkdir(parents=True)
        for index in range(2):
            image = rng.integers(0, 256, (40, 40, 3), dtype=np.uint8)
            cv2.imwrite(str(root / label / f"{index}.png"), image)
    return root


@pytest.mark.parametrize("before", [2, 3])
def test_jobs_1_reads_and_extracts_with_one_opencv_thread_and_restores_it(tmp_path, before):
    seen = []

    def read(path: Path) -> np.ndarray | None:
        seen.append(cv2.getNumThreads())
        return read_image_rgb(path)

    previous = cv2.getNumThreads()
    cv2.setNumThreads(before)
    try:
        scan = scan_image_folder(_folder(tmp_path / "images"))
        extract_feature_sets(scan, [ClassifierConfig()], read=read, jobs=1, progress=False)
        assert seen == [1] * 4
        assert cv2.getNumThreads() == before
    finally:
        cv2.setNumThreads(previous)
