"""The prediction summary's plain data, NaN as None (written for a mutation run's survivors)."""

from __future__ import annotations

import math

import numpy as np

from terrain_odom.evaluation import Windows, model_twist, prediction_errors
from terrain_odom.evaluation.prediction import PredictionSummary
from terrain_odom.kinematics import get_model
from terrain_odom.records import WheelLog


def test_summary_to_dict_names_each_figure_and_converts_the_heading():
    d = PredictionSummary(0.25, 0.5, 7).to_dict()
    assert d == {"position_m": 0.25, "heading_rad": 0.5, "heading_deg": math.degrees(0.5),
                 "count": 7}  # fmt: skip


def test_no_windows_give_nan_errors_written_as_none():
    log = WheelLog(np.arange(3.0), np.ones(3), np.ones(3), np.zeros((3, 3)), None,
                   np.zeros(3, int))  # fmt: skip
    empty = Windows(np.zeros(0, int), np.zeros(0, int), np.zeros(0))
    none = prediction_errors(log, empty, model_twist(get_model("idd"), [], 1.0))
    assert none.count == 0 and math.isnan(none.position) and math.isnan(none.heading)
    assert none.to_dict() == {
        "position_m": None,
        "heading_rad": None,
        "heading_deg": None,
        "count": 0,
    }
