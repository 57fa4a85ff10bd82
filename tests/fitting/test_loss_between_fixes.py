"""Residuals of segments between position fixes, worked by hand (``loss._turned_error``).

The ideal differential drive (idd, B = 1 m) on a hand-made block of three
two-step segments, so that every predicted path is known exactly.
"""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.fitting import parse_horizon, segment_set, training_windows
from terrain_odom.fitting.loss import residuals
from terrain_odom.fitting.segments import SegmentBlock, SegmentSet
from terrain_odom.kinematics import get_model
from terrain_odom.sim.model_log import constant_model_log
from tests.evaluation.test_sparse import _log


def _block() -> SegmentSet:
    # straight 2 m (twice) and a spin of 1 rad (0.5 rad a step)
    v_l = np.array([[1.0, 1.0], [1.0, 1.0], [-0.5, -0.5]])
    v_r = np.array([[1.0, 1.0], [1.0, 1.0], [0.5, 0.5]])
    dt = np.array([[1.0, 1.0], [1.0, 1.0], [0.5, 0.5]])
    target = np.full((3, 3), np.nan)
    target[:, 2] = [0.0, np.nan, 0.25]  # heading changes measured (the second: none)
    fixes = np.array([[True, False, True], [True, False, True], [True, False, False]])
    measured = np.zeros((3, 3, 2))
    measured[0, -1] = (3.0, 0.0)  # the end fix 3 m ahead where 2 m were driven
    measured[1, -1] = (0.0, 3.0)  # 3 m to the left: the start heading is fitted as +90 deg
    block = SegmentBlock(v_l, v_r, dt, target, fixes, measured)
    return SegmentSet((block,), 3, 7.0, float(dt.sum()))


def test_end_errors_in_the_world_frame_after_the_fitted_start_heading():
    res = residuals(get_model("idd"), np.zeros((1, 0)), _block(), track_width=1.0)
    expected = [
        [-1.0, 0.0, 0.0],  # 2 m driven along x, 3 m measured: 1 m short in x
        [0.0, -1.0, 0.0],  # turned onto the fix's direction: 1 m short in y; no heading measured
        [0.0, 0.0, 0.75],  # no end fix: no position error; turned 1 rad where 0.25 was measured
    ]
    np.testing.assert_allclose(res[0], expected, atol=1e-12)


def test_the_heading_error_is_the_end_heading_wrapped():
    segs = _block()
    block = segs.blocks[0]
    target = block.target.copy()
    target[2, 2] = 1.0 - 2 * np.pi + 0.1  # the same heading, one turn away, 0.1 rad short
    turned = SegmentBlock(block.v_l, block.v_r, block.dt, target, block.fixes, block.measured)
    res = residuals(
        get_model("idd"), np.zeros((1, 0)), SegmentSet((turned,), 3, 7.0, segs.duration),
        track_width=1.0,
    )  # fmt: skip
    assert res[0, 2, 2] == pytest.approx(-0.1, abs=1e-12)


@pytest.mark.parametrize("anchor", ["pose", "position", "heading"])
def test_segment_set_gives_the_fixes_their_displacements_or_neither(anchor):
    """So the loss never meets fixes without measured displacements (no such branch)."""
    if anchor == "pose":
        log = constant_model_log("idd", [], seconds=20.0)
    else:
        log = _log(positions=anchor == "position", headings=anchor == "heading")
    windows = training_windows(log, parse_horizon("3m"), anchor=anchor)
    segs = segment_set([log], [windows], anchor=anchor)
    assert segs.count > 3
    for block in segs.blocks:
        if anchor == "pose":
            assert block.fixes is None and block.measured is None
        else:
            assert block.fixes.shape == block.dt.shape[:1] + (block.dt.shape[1] + 1,)
            assert block.measured.shape == block.fixes.shape + (2,)
            assert not block.measured[~block.fixes].any()  # 0 where no fix
