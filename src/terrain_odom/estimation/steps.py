"""What :class:`~terrain_odom.estimation.online.OnlineOdometry` asks of an estimator.

Each estimator turns the stream's wheel samples and pose measurements into
filter steps its own way (:class:`~terrain_odom.estimation.icr_steps.IcrSteps`,
:class:`~terrain_odom.estimation.slip_steps.SlipSteps`); the streaming API
calls them through :class:`FilterSteps` only.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    import numpy as np

    from terrain_odom.estimation.pose_measurement import PoseUse
    from terrain_odom.estimation.terrain import RowFilter

__all__ = ["HEADING", "POSITION", "YAW", "FilterSteps", "RowBatch"]

YAW = 2
"""Index of ``yaw`` in a pose ``x, y, yaw``."""
POSITION, HEADING = "position", "heading"
"""The pose components counted by :class:`~terrain_odom.estimation.pose_measurement.PoseUse`."""


class RowBatch(Protocol):
    """Log rows run in one call, as :meth:`FilterSteps.batch` returns it."""

    def __call__(
        self,
        since: tuple[float, float, float],
        t: np.ndarray,
        speeds: tuple[np.ndarray, np.ndarray],
        pose: np.ndarray,
        use: PoseUse,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        """Predict and update over rows ``t``; count the poses in ``use``.

        ``since`` is the time (s) and track speeds (m/s) of the wheel sample
        before ``t[0]``; ``pose`` the measured ``x, y, yaw`` of each row (NaN
        where not measured). Returns the estimate and its standard deviation
        after each row, the ICR parameters after each row (what
        :meth:`FilterSteps.icr_params` returns then, shape (B, 3) or (B, 4)),
        and the number of poses that updated the filter.
        """
        ...  # pragma: no cover


class FilterSteps(Protocol):
    """An estimator's steps: predict at wheel samples, fuse pose measurements."""

    @property
    def filter(self) -> RowFilter:
        """The filter, whose terrain the terrain flow sets and resets."""
        ...  # pragma: no cover

    @property
    def names(self) -> tuple[str, ...]:
        """Names of the estimated values, in the order of :meth:`estimate`."""
        ...  # pragma: no cover

    def restart(self, t: float) -> None:
        """Start a segment at ``t`` (s): nothing is integrated across the break."""
        ...  # pragma: no cover

    def predict(self, v_l: float, v_r: float, dt: float) -> None:
        """Predict over ``dt`` s with the track speeds ``v_l, v_r`` (m/s) held."""
        ...  # pragma: no cover

    def sample(self, t: float, v_l: float, v_r: float) -> None:
        """Take note of the wheel sample at ``t`` (s) just predicted to."""
        ...  # pragma: no cover

    def measure(self, z: np.ndarray, rows: tuple[int, ...], use: PoseUse) -> bool:
        """Fuse the ``rows`` components of pose ``z``; return whether the filter updated."""
        ...  # pragma: no cover

    def icr_params(self, v_l: float, v_r: float) -> np.ndarray:
        """Return the current ``y_l, y_r, x_icr, alpha`` at track speeds ``v_l, v_r``."""
        ...  # pragma: no cover

    def estimate(self, v_l: float, v_r: float) -> tuple[np.ndarray, np.ndarray]:
        """Return the estimate and its standard deviation, in :attr:`names` order."""
        ...  # pragma: no cover

    def batch(self) -> RowBatch | None:
        """Return how to run log rows in one call from now on (None: one by one)."""
        ...  # pragma: no cover
