"""The identification loss: whitened end-of-segment pose errors (Baril et al. eq. 13).

.. math::

    l(\\mathbf{k}) = \\sum_{i=1}^N e_i^T \\Sigma^{-1} e_i,\\quad
    e_i = \\ominus(\\hat{x}_i) - \\ominus(x_i)

with the errors ``e_i = (dx, dy, wrap(dyaw))`` expressed in each segment's
start frame (for ``Sigma = I`` this equals the world-frame distance; Martinez
et al. 2004 eq. 14 is the same loss). :func:`residuals` returns ``L^T e``
with ``L L^T = Sigma^-1`` (:func:`whitener_matrix`), so the loss is their sum of
squares (:func:`squared_loss`).

Segments between position fixes (no start heading; a GPS and an IMU) are
compared as :mod:`~terrain_odom.evaluation.sparse` scores them: the
predicted antenna path turned by the start heading that best fits the
segment's fixes, its end against the end fix (``dx, dy`` in the world
frame), and the heading change against the heading rows' (0 where no
heading was measured).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from terrain_odom.evaluation.sparse import antenna_displacement, fitted_turn
from terrain_odom.fitting.segments import SegmentSet
from terrain_odom.kinematics.integration import integrate, wrap_angle
from terrain_odom.kinematics.models import KinematicModel

__all__ = ["residuals", "whitener_matrix", "squared_loss"]

_INVALID_LOSS = 1e12  # loss of parameter sets whose twist is not finite (e.g. ROC with y_0 <= 0)


def whitener_matrix(sigma: ArrayLike | None) -> np.ndarray:
    """Matrix ``L`` with ``L @ L.T = inv(Sigma)`` (identity for ``None``), shape (3, 3)."""
    if sigma is None:
        return np.eye(3)
    s = np.asarray(sigma, dtype=float)
    if s.shape == (3,):
        if not np.all(s > 0.0):
            raise ValueError(f"sigma standard deviations must be > 0, got {s.tolist()}")
        return np.diag(1.0 / s)
    if s.shape != (3, 3) or not np.allclose(s, s.T):
        raise ValueError(f"Sigma must be 3 standard deviations or a symmetric 3x3, got {s}")
    try:
        return np.linalg.cholesky(np.linalg.inv(s))
    except np.linalg.LinAlgError:
        raise ValueError(f"Sigma must be positive definite, got {s.tolist()}") from None


def residuals(
    model: KinematicModel,
    params: ArrayLike,
    segments: SegmentSet,
    *,
    whitener: np.ndarray | None = None,
    track_width: float | None = None,
) -> np.ndarray:
    """Whitened end-of-segment pose errors of one or many parameter sets.

    Parameters
    ----------
    model : KinematicModel
        The model.
    params : array_like, shape (S, k)
        ``S`` parameter sets (a DE population) in ``model.param_names`` order.
    segments : SegmentSet
        Training segments.
    whitener : ndarray, shape (3, 3), optional
        ``L`` with ``L L^T = Sigma^-1``; identity if omitted.
    track_width : float, optional
        Nominal ``B``, m, for models that need it.

    Returns
    -------
    ndarray, shape (S, N, 3)
        ``L^T e`` per segment, so that the loss is the sum of squares.
    """
    p = np.asarray(params, dtype=float)[:, None, :]  # (S, 1, k): broadcasts over (W, K)
    out = []
    for block in segments.blocks:
        v_x, v_y, omega = model.twist(block.v_l, block.v_r, p, track_width)
        shape = (p.shape[0], *block.dt.shape)  # (S, W, K), also for idd (no parameter)
        v_x, v_y, omega, dt = (np.broadcast_to(c, shape) for c in (v_x, v_y, omega, block.dt))
        poses = integrate(v_x, v_y, omega, dt)
        if block.fixes is None:
            err = poses[..., -1, :] - block.target
            err[..., 2] = wrap_angle(err[..., 2])
        else:
            assert block.measured is not None  # _block sets both or neither
            err = _turned_error(poses, block.fixes, block.measured, block.target, segments.antenna)
        out.append(err)
    err = np.concatenate(out, axis=1)
    return err if whitener is None else err @ whitener


def _turned_error(
    poses: np.ndarray,
    fixes: np.ndarray,
    measured: np.ndarray,
    target: np.ndarray,
    antenna: tuple[float, float],
) -> np.ndarray:
    """End errors of segments between fixes, shape (S, W, 3): start heading fitted to the fixes.

    ``fixes``, ``measured`` and ``target`` as in a segment block; ``poses``
    ``(S, W, K + 1, 3)`` integrated from the origin.
    """
    q = antenna_displacement(poses, antenna)  # (S, W, K + 1, 2)
    theta = fitted_turn(q, measured, fixes)
    c, s = np.cos(theta), np.sin(theta)
    q_end, d_end = q[..., -1, :], measured[:, -1]
    err = np.empty(poses.shape[:-2] + (3,))
    err[..., 0] = c * q_end[..., 0] - s * q_end[..., 1] - d_end[:, 0]
    err[..., 1] = s * q_end[..., 0] + c * q_end[..., 1] - d_end[:, 1]
    err[..., :2] *= fixes[:, -1, None]  # segments between heading rows: no position error
    err[..., 2] = np.nan_to_num(wrap_angle(poses[..., -1, 2] - target[:, 2]))
    return err


def squared_loss(res: np.ndarray) -> np.ndarray:
    """Sum of squares per parameter set; non-finite sets get a large finite loss."""
    loss = np.sum(res * res, axis=(-2, -1))
    return np.where(np.isfinite(loss), loss, _INVALID_LOSS)
