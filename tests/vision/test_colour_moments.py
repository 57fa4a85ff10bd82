"""Colour statistics by exact integer sums: bit for bit OpenCV's ``meanStdDev``."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from terrain_odom.io.images import read_image_rgb
from terrain_odom.vision.features import _mean_std, colour_statistics


def _opencv(converted: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    mean, std = cv2.meanStdDev(np.ascontiguousarray(converted))
    return mean.ravel(), std.ravel()


def _crops(image: np.ndarray, rng: np.random.Generator, n: int) -> list[np.ndarray]:
    """``n`` crops of random sizes (1 px to 200 px a side) and places, as views."""
    crops = []
    for _ in range(n):
        h = int(rng.integers(1, min(200, image.shape[0]) + 1))
        w = int(rng.integers(1, min(200, image.shape[1]) + 1))
        y = int(rng.integers(0, image.shape[0] - h + 1))
        x = int(rng.integers(0, image.shape[1] - w + 1))
        crops.append(image[y : y + h, x : x + w])
    return crops


@pytest.mark.parametrize("code", [cv2.COLOR_RGB2Lab, cv2.COLOR_RGB2HSV])
def test_mean_and_std_are_opencvs_bit_for_bit_on_real_floor_crops(indoor_dir, code):
    rng = np.random.default_rng(4)
    photos = sorted(indoor_dir.rglob("*.jpg"))[::60]
    assert len(photos) >= 20
    checked = 0
    for photo in photos:
        converted = cv2.cvtColor(read_image_rgb(photo), code)
        for crop in _crops(converted, rng, 8):
            mean, std = _mean_std(crop)
            expected_mean, expected_std = _opencv(crop)
            np.testing.assert_array_equal(mean, expected_mean)
            np.testing.assert_array_equal(std, expected_std)
            checked += 1
    assert checked >= 160


def test_mean_and_std_are_opencvs_on_noise_flat_and_extreme_images():
    rng = np.random.default_rng(11)
    images = [
        rng.integers(0, 256, (480, 640, 3), dtype=np.uint8),  # a whole frame of noise
        np.full((37, 53, 3), 255, dtype=np.uint8),  # the largest squares; std 0
        np.zeros((1, 1, 3), dtype=np.uint8),
        np.dstack([np.full((9, 9), v, dtype=np.uint8) for v in (0, 128, 255)]),
        rng.choice(np.array([0, 255], dtype=np.uint8), (64, 65, 3)),  # the largest spread
    ]
    for image in images:
        mean, std = _mean_std(image)
        expected_mean, expected_std = _opencv(image)
        np.testing.assert_array_equal(mean, expected_mean)
        np.testing.assert_array_equal(std, expected_std)
    mean, std = _mean_std(images[4])
    assert np.all(np.abs(mean - 127.5) < 2.0) and np.all(np.abs(std - 127.5) < 0.1)


def test_colour_statistics_interleave_each_channels_mean_and_std():
    image = np.zeros((2, 2, 3), dtype=np.uint8)
    image[0] = (255, 255, 255)  # half white, half black
    lab = colour_statistics(image, "lab")
    assert lab.tolist()[:2] == [127.5, 127.5]  # L: 0 and 255, mean 127.5, std 127.5
    assert lab.tolist()[2:] == [128.0, 0.0, 128.0, 0.0]  # grey: a and b at their offset 128
