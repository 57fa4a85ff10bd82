"""Tests of the per-frame helpers of terrain_odom.app.frames."""

from __future__ import annotations

import cv2
import pytest
from threadpoolctl import threadpool_info

from terrain_odom.app.frames import one_thread


def test_one_thread_limits_every_pool_and_restores_them():
    before_cv2 = cv2.getNumThreads()
    before = {(p["internal_api"], p["filepath"]): p["num_threads"] for p in threadpool_info()}
    with one_thread():
        assert cv2.getNumThreads() == 1
        assert all(p["num_threads"] == 1 for p in threadpool_info())
    assert cv2.getNumThreads() == before_cv2
    after = {(p["internal_api"], p["filepath"]): p["num_threads"] for p in threadpool_info()}
    assert after == before
    with pytest.raises(RuntimeError), one_thread():  # restored after an error too
        raise RuntimeError
    assert cv2.getNumThreads() == before_cv2
