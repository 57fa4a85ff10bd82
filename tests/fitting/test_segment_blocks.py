"""``segment_set``: its inputs checked against each other, and the fixes it keeps."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

from terrain_odom.fitting import parse_horizon, segment_set, training_windows
from terrain_odom.sim.model_log import constant_model_log
from tests.evaluation.test_sparse import _log


def test_one_windows_and_one_anchor_per_log():
    log = constant_model_log("idd", [], seconds=10.0)
    windows = training_windows(log, parse_horizon("2m"))
    assert segment_set([log, log], [windows, windows]).count == 2 * len(windows)
    with pytest.raises(ValueError, match="zip"):
        segment_set([log, log], [windows])
    with pytest.raises(ValueError, match="zip"):
        segment_set([log], [windows], anchor=["pose", "pose"])


def test_segments_between_fixes_keep_every_fix_inside_them():
    smooth = _log(positions=True, headings=False)
    held = np.arange(len(smooth)) // 5 * 5  # each wheel reading held for 5 rows, as logs do
    log = dataclasses.replace(smooth, v_l=smooth.v_l[held], v_r=smooth.v_r[held])
    windows = training_windows(log, parse_horizon("3m"), anchor="position")
    segs = segment_set([log], [windows], anchor="position")
    fixes_in_windows = sum(
        int(log.has_position[s : e + 1].sum())
        for s, e in zip(windows.start, windows.end, strict=True)
    )
    assert fixes_in_windows > 3 * len(windows)  # fixes at 2.5 Hz: several inside each segment
    assert sum(int(b.fixes.sum()) for b in segs.blocks) == fixes_in_windows
    # the held readings are merged into one step each between fixes
    assert sum(int(b.dt.astype(bool).sum()) for b in segs.blocks) < 0.5 * int(
        (windows.end - windows.start).sum()
    )


def test_a_terrain_is_selected_only_from_a_log_with_a_terrain_column():
    log = constant_model_log("idd", [], seconds=10.0)
    message = f"{log.source}: no terrain column, cannot select terrain 'grass'"
    with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
        training_windows(log, parse_horizon("2m"), terrain="grass")
