"""Short-term prediction error (the 2016 slip-model paper's metric).

At each measurement time ``t_i`` (a row with a full pose measurement, or a
given subset of them) the model is integrated from the *measured* pose at
``t_i`` with the parameters estimated at ``t_i`` (no later information) and
the recorded wheel speeds of the next ``horizon`` seconds, and compared with
the measured pose at the end. The end is the full-pose row of the same
segment whose time is nearest ``t_i + horizon``, if it is within
``tolerance`` seconds of it; the integration runs exactly from ``t_i`` to
that row's time. Reported: mean position error (m) and mean absolute heading
error (rad), for any twist callable, so the slip EKF, the ICR EKF and the
ideal differential drive share this code.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from terrain_odom.evaluation.metrics import TwistFn, window_errors
from terrain_odom.evaluation.windows import Windows
from terrain_odom.kinematics.slip import SlipModel
from terrain_odom.records import WheelLog

__all__ = [
    "PredictionSummary",
    "prediction_errors",
    "slip_twist_from_rows",
]


@dataclass(frozen=True)
class PredictionSummary:
    """Mean prediction errors over the windows.

    Attributes
    ----------
    position : float
        Mean distance between predicted and measured end positions, m.
    heading : float
        Mean absolute wrapped heading difference at the end, rad.
    count : int
        Number of windows.
    """

    position: float
    heading: float
    count: int

    def to_dict(self) -> dict[str, float | int | None]:
        """Plain data for JSON (NaN as None)."""
        nan = np.isnan
        return {
            "position_m": None if nan(self.position) else self.position,
            "heading_rad": None if nan(self.heading) else self.heading,
            "heading_deg": None if nan(self.heading) else float(np.degrees(self.heading)),
            "count": self.count,
        }


def prediction_errors(log: WheelLog, windows: Windows, twist_fn: TwistFn) -> PredictionSummary:
    """Mean position and heading error of a model's predictions over the windows.

    Parameters
    ----------
    log : WheelLog
        The reference log.
    windows : Windows
        From :func:`prediction_windows`.
    twist_fn : TwistFn
        ``twist_fn(v_l, v_r, window_index)``, e.g.
        :func:`~terrain_odom.evaluation.model_twist`,
        :func:`~terrain_odom.evaluation.icr_twist_from_rows` or
        :func:`slip_twist_from_rows`.

    Returns
    -------
    PredictionSummary
    """
    if len(windows) == 0:
        return PredictionSummary(float("nan"), float("nan"), 0)
    err = window_errors(log, windows, twist_fn)
    return PredictionSummary(
        float(err.translation.mean()), float(err.rotation.mean()), len(windows)
    )


def slip_twist_from_rows(windows: Windows, params: ArrayLike, model: SlipModel) -> TwistFn:
    """Twist callable of the slip model with parameters given per log row.

    Each window uses the parameters of its start row only; the ICRs follow
    the features of every wheel sample in the window.

    Parameters
    ----------
    windows : Windows
        The windows the callable will be evaluated on.
    params : array_like, shape (N, n)
        ``l1 .. l6(, alpha)`` per log row.
    model : SlipModel
        Track width, feature settings and ICR limits.

    Returns
    -------
    TwistFn
    """
    per_window = np.asarray(params, dtype=float)[windows.start]

    def twist_fn(v_l: np.ndarray, v_r: np.ndarray, window_index: np.ndarray) -> tuple:
        return model.twist(v_l, v_r, per_window[window_index][:, None, :])

    return twist_fn
