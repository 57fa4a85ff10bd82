"""Evaluation of odometry: model error over spatial windows and ATE."""

from terrain_odom.evaluation.metrics import (
    DEFAULT_HORIZON,
    AteResult,
    ErrorStats,
    ErrorSummary,
    SE2Alignment,
    TwistFn,
    WindowErrors,
    Windows,
    absolute_trajectory_error,
    align_se2,
    icr_twist_from_rows,
    model_twist,
    predict_window_ends,
    spatial_windows,
    summarize,
    window_errors,
)

__all__ = [
    "DEFAULT_HORIZON",
    "AteResult",
    "ErrorStats",
    "ErrorSummary",
    "SE2Alignment",
    "TwistFn",
    "WindowErrors",
    "Windows",
    "absolute_trajectory_error",
    "align_se2",
    "icr_twist_from_rows",
    "model_twist",
    "predict_window_ends",
    "spatial_windows",
    "summarize",
    "window_errors",
]
