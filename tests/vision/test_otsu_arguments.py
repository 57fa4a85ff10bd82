"""``multiotsu_thresholds``: the smallest histogram it takes, and its refusals in full."""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.vision.sfta import multiotsu_thresholds


def test_a_single_pixel_is_a_histogram():
    hist = np.zeros(256, dtype=int)
    hist[7] = 1
    # one level: every threshold is that level, the classes above it empty
    assert multiotsu_thresholds(hist, 4).tolist() == [7, 7, 7, 7]


def test_refusals_name_the_cause():
    with pytest.raises(ValueError, match=r"^hist must hold 256 non-negative integer counts$"):
        multiotsu_thresholds(np.ones(255), 2)
    with pytest.raises(ValueError, match=r"^hist is empty: its counts sum to 0$"):
        multiotsu_thresholds(np.zeros(256), 2)
