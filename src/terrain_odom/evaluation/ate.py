"""Absolute trajectory error: an estimated planar trajectory against measured positions.

:func:`absolute_trajectory_error` aligns the estimate to the measured
positions with the rigid SE(2) transform that minimises the squared position
error (:func:`align_se2`: Umeyama without scale, with the reflection guard)
and returns the RMSE; it equals evo's APE RMSE after ``align`` (tested).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from terrain_odom.kinematics.integration import wrap_angle

__all__ = ["SE2Alignment", "AteResult", "align_se2", "absolute_trajectory_error"]


@dataclass(frozen=True)
class SE2Alignment:
    """A planar rigid transform ``p -> R(angle) p + translation``.

    Attributes
    ----------
    angle : float
        Rotation angle, rad, in (-pi, pi].
    translation : ndarray, shape (2,)
        Translation, m.
    """

    angle: float
    translation: np.ndarray

    @property
    def rotation(self) -> np.ndarray:
        """Rotation matrix, shape (2, 2)."""
        c, s = math.cos(self.angle), math.sin(self.angle)
        return np.array([[c, -s], [s, c]])

    def apply(self, xy: ArrayLike) -> np.ndarray:
        """Transform positions of shape (..., 2), m."""
        return np.asarray(xy, dtype=float) @ self.rotation.T + self.translation


@dataclass(frozen=True)
class AteResult:
    """Absolute trajectory error after SE(2) alignment.

    Attributes
    ----------
    rmse : float
        Root-mean-square position error after alignment, m.
    alignment : SE2Alignment
        Transform applied to the estimate to align it with the reference.
    count : int
        Number of rows compared.
    """

    rmse: float
    alignment: SE2Alignment
    count: int

    def to_dict(self) -> dict[str, float | int | list[float]]:
        """JSON-ready dict: ``rmse_m``, ``angle_rad``, ``translation_m``, ``count``."""
        return {
            "rmse_m": self.rmse,
            "angle_rad": self.alignment.angle,
            "translation_m": self.alignment.translation.tolist(),
            "count": self.count,
        }


def align_se2(source_xy: ArrayLike, target_xy: ArrayLike) -> SE2Alignment:
    """Rigid planar transform that best maps ``source`` onto ``target``.

    Closed-form least squares (Kabsch/Umeyama without scale) with the
    reflection guard, so the result is a proper rotation.

    Parameters
    ----------
    source_xy, target_xy : array_like, shape (M, 2)
        Corresponding positions, m; ``M >= 2``.

    Returns
    -------
    SE2Alignment
        ``T`` minimising ``sum |T(source_i) - target_i|^2``.

    Examples
    --------
    >>> src = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 2.0]])
    >>> a = align_se2(src, src @ np.array([[0.0, -1.0], [1.0, 0.0]]).T + [3.0, 4.0])
    >>> round(a.angle, 9), a.translation.round(9).tolist()
    (1.570796327, [3.0, 4.0])
    """
    src = np.asarray(source_xy, dtype=float)
    dst = np.asarray(target_xy, dtype=float)
    if src.shape != dst.shape or src.ndim != 2 or src.shape[1] != 2 or src.shape[0] < 2:
        raise ValueError(
            f"need two (M, 2) position arrays with M >= 2, got {src.shape} and {dst.shape}"
        )
    mu_src, mu_dst = src.mean(axis=0), dst.mean(axis=0)
    cov = (dst - mu_dst).T @ (src - mu_src)
    u, _, vt = np.linalg.svd(cov)
    guard = np.diag([1.0, np.sign(np.linalg.det(u) * np.linalg.det(vt))])
    rot = u @ guard @ vt
    angle = float(wrap_angle(math.atan2(rot[1, 0], rot[0, 0])))
    return SE2Alignment(angle=angle, translation=mu_dst - rot @ mu_src)


def absolute_trajectory_error(est_xy: ArrayLike, ref_xy: ArrayLike) -> AteResult:
    """Absolute trajectory error (position RMSE) after SE(2) alignment.

    Parameters
    ----------
    est_xy : array_like, shape (N, 2)
        Estimated positions per log row, m.
    ref_xy : array_like, shape (N, 2)
        Measured positions at the same rows, m; NaN where not measured.
        Only rows finite in both are used (at least 2).

    Returns
    -------
    AteResult
        RMSE (m), the alignment applied to the estimate and the row count.
    """
    est = np.asarray(est_xy, dtype=float)
    ref = np.asarray(ref_xy, dtype=float)
    if est.shape != ref.shape:
        raise ValueError(f"estimate and reference shapes differ: {est.shape} vs {ref.shape}")
    both = np.isfinite(est).all(axis=-1) & np.isfinite(ref).all(axis=-1)
    alignment = align_se2(est[both], ref[both])
    residual = alignment.apply(est[both]) - ref[both]
    rmse = float(np.sqrt(np.mean(np.sum(residual**2, axis=1))))
    return AteResult(rmse=rmse, alignment=alignment, count=int(both.sum()))
