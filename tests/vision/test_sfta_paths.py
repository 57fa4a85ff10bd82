"""SFTA's less travelled paths: n_t levels exactly, huge histograms, the float32 pass's gate."""

from __future__ import annotations

import re

import numpy as np
import pytest

from terrain_odom.vision import sfta
from terrain_odom.vision.sfta import multiotsu_thresholds, sfta_features

FLOAT32_EXACT = 2**24  # the largest run of integers float32 holds exactly


def test_a_float_image_is_refused_with_the_conversion_to_use():
    message = (
        "image must be uint8, got float64; convert a float image in [0, 1] "
        "with (image * 255).round().astype(np.uint8)"
    )
    with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
        sfta_features(np.zeros((4, 4)))


def test_exactly_n_t_levels_are_the_thresholds_as_bytes():
    hist = np.zeros(256, dtype=int)
    hist[[10, 40, 90, 200]] = [5, 1, 7, 2]
    thresholds = multiotsu_thresholds(hist, 4)
    assert thresholds.tolist() == [10, 40, 90, 200]  # every level a class, the last class empty
    assert thresholds.dtype == np.uint8
    hist[250] = 3  # one level more: a proper split, still bytes
    assert multiotsu_thresholds(hist, 4).dtype == np.uint8


def test_a_histogram_past_calchist_range_has_all_256_levels():
    grey = np.zeros((4097, 4097), dtype=np.uint8)  # 2**24 + 8195 pixels: counted by bincount
    grey[:, 0] = 3
    hist = sfta._histogram(grey)
    assert hist.shape == (256,)
    assert hist[0] == 4097 * 4096 and hist[3] == 4097 and hist.sum() == grey.size


def test_float32_is_tried_only_when_every_partial_sum_is_exact_in_it(monkeypatch):
    tried = []
    dp = sfta._otsu_dp

    def recording(cumulative, n_t, dtype):
        tried.append(dtype)
        return dp(cumulative, n_t, dtype)

    monkeypatch.setattr(sfta, "_otsu_dp", recording)
    # h pixels at 100 and 101 and one at 99: the mean rounds to 100, and the grey sums
    # relative to it rise from -1 to h - 1 (n / 2 + 1 away from the lowest, n = 2 h + 1)
    for h, first in ((FLOAT32_EXACT // 4, np.float32), (FLOAT32_EXACT, np.float64)):
        tried.clear()
        hist = np.zeros(256)
        hist[[99, 100, 101]] = [1, h, h]
        assert multiotsu_thresholds(hist, 1).tolist() == [100]
        assert tried[0] is first
