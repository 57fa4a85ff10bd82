"""Robust and circular statistics of the sensor calibration and its checks.

The standard deviation of a normal sample from its median absolute
deviation (:data:`MAD_TO_STD`), the median of angles on the circle
(:func:`circular_median`), and the integrated autocorrelation time of a
sequence (:func:`correlation_time`: how many samples count as one
independent one when a standard error is taken).
"""

from __future__ import annotations

import numpy as np

from terrain_odom.kinematics import wrap_angle

__all__ = ["MAD_TO_STD", "circular_median", "correlation_time"]

MAD_TO_STD = 1.4826
"""Ratio of the standard deviation to the median absolute deviation of a normal sample."""


def circular_median(angles: np.ndarray, weights: np.ndarray | None = None) -> float:
    """Return the (weighted) median of angles on the circle, rad in (-pi, pi].

    The angles are unwrapped around their circular mean first, so a cluster
    around +-pi is not split into two halves (a plain median of wrapped
    angles near +-pi falls between them).

    Examples
    --------
    >>> round(float(np.degrees(circular_median(np.radians([179.0, -179.0, 178.0])))), 6)
    179.0
    """
    a = np.asarray(angles, dtype=float)
    w = np.ones(a.size) if weights is None else np.asarray(weights, dtype=float)
    centre = float(np.angle(np.sum(w * np.exp(1j * a))))
    dev = wrap_angle(a - centre)
    return float(wrap_angle(centre + _weighted_median(dev, w)))


def _weighted_median(x: np.ndarray, w: np.ndarray) -> float:
    order = np.argsort(x)
    cum = np.cumsum(w[order])
    return float(x[order][np.searchsorted(cum, 0.5 * cum[-1])])


def correlation_time(x: np.ndarray) -> float:
    """Integrated autocorrelation time of a sequence, in samples (>= 1; Geyer's initial sum)."""
    x = x - np.mean(x)
    var = float(x @ x)
    if x.size < 4 or var == 0.0:
        return 1.0
    tau = 1.0
    for lag in range(1, x.size // 2):
        rho = float(x[:-lag] @ x[lag:]) / var
        if rho <= 0.0:
            break
        tau += 2.0 * rho
    return tau
