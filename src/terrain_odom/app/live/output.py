"""What the live odometry gives after each row: the estimate and the body twist with its covariance."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from terrain_odom.kinematics.models import twist_icr, twist_icr_jacobian
from terrain_odom.records import TerrainChange

__all__ = ["LiveOutput", "twist_with_covariance"]


@dataclass(frozen=True)
class LiveOutput:
    """The estimate after one row: what the node publishes.

    Attributes
    ----------
    stamp_ns : int
        The row's stamp (ns, the messages' clock).
    t : float
        The row's time on the log clock (s since the time origin, as ``run``'s).
    names : tuple of str
        Names of ``state`` and ``std`` (:attr:`OnlineOdometry.names`).
    state, std : ndarray
        Estimate and standard deviations.
    twist, twist_cov : ndarray, shape (3,), (3, 3)
        Body twist ``v_x, v_y, omega`` (m/s, m/s, rad/s) of the held wheel
        speeds and the current ICRs, and its covariance from theirs.
    terrain : str
        Terrain applied to the filter (``""`` before any).
    changes : tuple of TerrainChange
        Terrain changes applied since the previous output.
    """

    stamp_ns: int
    t: float
    names: tuple[str, ...]
    state: np.ndarray
    std: np.ndarray
    twist: np.ndarray
    twist_cov: np.ndarray
    terrain: str
    changes: tuple[TerrainChange, ...] = ()


def twist_with_covariance(
    v_l: float, v_r: float, names: tuple[str, ...], state: np.ndarray, std: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Body twist of the ICR model and its covariance, the ICR errors taken independent.

    ``Sigma_twist = J diag(std_icr^2) J^T`` with ``J`` the Jacobian of
    :func:`~terrain_odom.kinematics.models.twist_icr` in ``y_l, y_r, x_icr,
    alpha`` (``alpha`` 1 with zero variance when not estimated).

    Examples
    --------
    >>> names = ("x", "y", "yaw", "y_l", "y_r", "x_icr")
    >>> twist, cov = twist_with_covariance(1.0, 1.0, names, np.r_[0, 0, 0, .5, -.5, 0.],
    ...                                    np.r_[0, 0, 0, .1, .1, .1])
    >>> twist.tolist(), bool(np.all(cov == 0.0))  # straight ahead: no ICR error matters
    ([1.0, -0.0, 0.0], True)
    """
    index = [names.index(n) for n in ("y_l", "y_r", "x_icr")]
    params = [float(state[i]) for i in index]
    sigmas = [float(std[i]) for i in index]
    if "alpha" in names:
        params.append(float(state[names.index("alpha")]))
        sigmas.append(float(std[names.index("alpha")]))
    else:
        params.append(1.0)
        sigmas.append(0.0)
    twist = np.array(twist_icr(v_l, v_r, *params), dtype=float)
    jac = np.asarray(twist_icr_jacobian(v_l, v_r, *params), dtype=float)
    return twist, (jac * np.square(sigmas)) @ jac.T
