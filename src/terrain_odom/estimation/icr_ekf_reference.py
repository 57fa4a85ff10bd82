"""The ICR EKF in its filterpy formulation: the reference of the compiled kernels.

:class:`FilterpyIcrEkf` is :class:`~terrain_odom.estimation.icr_ekf.IcrEkf`
with predict and update done as before the kernels of
:mod:`terrain_odom.estimation._kernels`: a filterpy ``ExtendedKalmanFilter``
whose prediction is :func:`~terrain_odom.estimation.icr_model.icr_step_with_jacobian`,
filterpy's Joseph-form update with SciPy's inverse and the pose sensors'
:func:`~terrain_odom.estimation.pose_measurement.measurement` after a chi-square
gate in numpy, numpy clipping; a heading bias state (``heading_bias``) enters
the step's Jacobian as its decay and the heading's ``H`` as a 1. Everything
else (terrain resets, memory, priors) is inherited, so both run the same logs
through the same streaming path (a stretch of rows through the reference's
own predict and update, row by row). The tests hold the kernels to it within
1e-12 and ``bench/ekf_speed.py`` times both; it is ~100x slower, and imports
filterpy (and SciPy's statistics) on first use.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike

from terrain_odom.errors import EstimationError
from terrain_odom.estimation._kernels import REACQUIRED_NIS
from terrain_odom.estimation.icr_ekf import IcrEkf, gate_bounds
from terrain_odom.estimation.icr_model import icr_step_with_jacobian
from terrain_odom.estimation.pose_measurement import measured_rows, measurement
from terrain_odom.kinematics import wrap_angle

__all__ = ["FilterpyIcrEkf"]


def _filterpy_ekf(x: np.ndarray, p: np.ndarray, tau: float | None = None) -> Any:
    """Return a filterpy EKF at state ``x`` and covariance ``p`` predicting with the ICR step.

    ``tau``: the last state is a heading bias with this time constant, s.
    """
    from filterpy.kalman import ExtendedKalmanFilter

    class _Filter(ExtendedKalmanFilter):
        x: np.ndarray  # state, shape (n, 1) (filterpy is untyped)
        F: np.ndarray  # noqa: N815 - filterpy's name of the process Jacobian

        def predict_x(self, u: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
            state, self.F = icr_step_with_jacobian(self.x[:, 0], *u, tau=tau)
            self.x = state[:, None]

    ekf = _Filter(dim_x=x.size, dim_z=3)
    ekf.x, ekf.P = x[:, None].copy(), p.copy()
    return ekf


def _hold_alpha(ekf: Any, x: np.ndarray, p: np.ndarray, jac: np.ndarray, r: np.ndarray) -> None:
    """Redo filterpy's update from prior ``x, p`` with alpha's gain row zero (a Schmidt update).

    The state moves by the gain with that row zero; ``P`` follows the Joseph
    form ``(I - K H) P (I - K H)^T + K R K^T``, the covariance of any gain.
    """
    gain = ekf.K.copy()
    gain[6] = 0.0
    i_kh = np.eye(x.size) - gain @ jac
    ekf.K = gain
    ekf.x = x[:, None] + gain @ ekf.y
    ekf.P = i_kh @ p @ i_kh.T + gain @ r @ gain.T


class FilterpyIcrEkf(IcrEkf):
    """:class:`~terrain_odom.estimation.icr_ekf.IcrEkf` through filterpy (same parameters).

    Examples
    --------
    >>> from terrain_odom.config import EkfConfig
    >>> ekf, ref = IcrEkf(EkfConfig()), FilterpyIcrEkf(EkfConfig())
    >>> for f in (ekf, ref):
    ...     f.predict(0.8, 1.0, 0.1)
    ...     _ = f.update([0.1, 0.0, 0.02])
    >>> bool(np.allclose(ekf.P, ref.P, rtol=0, atol=1e-14))
    True
    """

    def predict(self, v_l: float, v_r: float, dt: float) -> None:
        """Propagate over one wheel sample (see :meth:`IcrEkf.predict`)."""
        if not dt > 0.0:
            raise EstimationError(f"predict needs dt > 0 s, got {dt}")
        bias = self.heading_bias
        ekf = _filterpy_ekf(self._x, self._P, None if bias is None else bias.tau)
        ekf.Q = np.diag(self._q_density * dt)
        if bias is not None:  # exact: the stationary variance times 1 - exp(-2 dt / tau)
            ekf.Q[-1, -1] = bias.sigma**2 * -np.expm1(-2.0 * dt / bias.tau)
        ekf.predict(u=(float(v_l), float(v_r), float(dt)))
        self._x[:] = ekf.x[:, 0]
        self._P[:] = 0.5 * (ekf.P + ekf.P.T)
        self.t += dt

    def update(self, z: ArrayLike, *, R: ArrayLike | None = None) -> float:  # noqa: N803
        """Fuse a pose measurement (see :meth:`IcrEkf.update`)."""
        z = np.asarray(z, dtype=float)
        r_full = np.diag(self._r_diag) if R is None else np.asarray(R, dtype=float)
        r_full = np.diag(r_full) if r_full.ndim == 1 else r_full
        rows = self._gated_rows(z, measured_rows(z), r_full)
        if rows.size == 0:
            return float("nan")
        yaw_row = np.flatnonzero(rows == 2)

        def residual(a: np.ndarray, b: np.ndarray) -> np.ndarray:
            res = a - b
            res[yaw_row] = wrap_angle(res[yaw_row])
            return res

        h, H = self._measurement(rows)  # noqa: N806
        r = r_full[np.ix_(rows, rows)]
        ekf = _filterpy_ekf(self._x, self._P)
        ekf.update(  # filterpy evaluates both at the prior state
            z[rows][:, None],
            HJacobian=lambda _x: H,
            Hx=lambda _x: h[:, None],
            R=r,
            residual=residual,
        )
        if self._model > 6 and rows[0] == 2:  # heading only: alpha not observable, held
            _hold_alpha(ekf, self._x, self._P, H, r)
        self.last_nis = float((ekf.y.T @ ekf.SI @ ekf.y).item())
        self._x[:], self._P[:] = ekf.x[:, 0], ekf.P
        self._constrain()
        return self.last_nis

    def run_rows(
        self,
        since: tuple[float, float, float],
        t: np.ndarray,
        speeds: tuple[np.ndarray, np.ndarray],
        z: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, int]:
        """Predict and update row by row (see :meth:`IcrEkf.run_rows`), through filterpy."""
        held_t, v_l, v_r = since
        states, stds = np.empty((t.size, self._x.size)), np.empty((t.size, self._x.size))
        updates = 0
        for i in range(t.size):
            self.predict(v_l, v_r, t[i] - held_t)
            held_t, v_l, v_r = t[i], speeds[0][i], speeds[1][i]
            updates += not np.isnan(self.update(z[i]))
            states[i], stds[i] = self._x, np.sqrt(np.maximum(np.diag(self._P), 0.0))
        return states, stds, updates

    def _gated_rows(self, z: np.ndarray, rows: np.ndarray, r_full: np.ndarray) -> np.ndarray:
        """Return the measured ``rows`` that pass the chi-square gate (see :meth:`IcrEkf.update`).

        The position's NIS is that of its 2x2 block of ``S = H P H^T + R``
        (SciPy's inverse), the heading's its innovation squared over its
        variance in ``S``; a re-acquired component beyond ``REACQUIRED_NIS`` bounds grows the
        pose variances it measures by ``S``'s in proportion (:attr:`gating` as
        the kernels keep it).
        """
        if rows.size == 0:
            return rows
        h, H = self._measurement(rows)  # noqa: N806
        y = z[rows] - h
        y[rows == 2] = wrap_angle(y[rows == 2])
        s = H @ self._P @ H.T + r_full[np.ix_(rows, rows)]
        gate, bounds = self.config.gate, gate_bounds(self.config.gate)
        keep: list[int] = []
        for g, part in enumerate((np.flatnonzero(rows < 2), np.flatnonzero(rows == 2))):
            if part.size == 0:
                continue
            nis = y[part] @ scipy.linalg.inv(s[np.ix_(part, part)]) @ y[part]
            if not nis > bounds[g]:
                self.gating[[g, 2 + g]] = np.nan, 0.0
            else:
                if np.isnan(self.gating[g]):
                    self.gating[g] = self.t
                in_row = self.gating[2 + g]
                if in_row < gate.reacquire_after and self.t - self.gating[g] < gate.reacquire:
                    self.gating[[2 + g, 4 + g]] += 1
                    continue
                self.gating[[g, 2 + g]] = np.nan, 0.0
                self.gating[6 + g] += 1
                grow = max(nis / (REACQUIRED_NIS * bounds[g]) - 1.0, 0.0)
                self._P[rows[part], rows[part]] += grow * np.diag(s)[part]
            keep.extend(rows[part])
        return np.array(keep, dtype=int)

    def _measurement(self, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Return the pose sensors' ``h`` and ``H``; a heading bias state adds to the heading."""
        h, H = measurement(self._x, rows, self.mounting)  # noqa: N806
        if self.heading_bias is not None:
            yaw = rows == 2
            h[yaw] = wrap_angle(h[yaw] + self._x[-1])
            H[yaw, -1] = 1.0
        return h, H

    def _constrain(self) -> None:
        """Wrap yaw (and a heading bias), clip the ICR state into its limits (numpy), symmetrise P."""
        x, lim = self._x, self.limits
        x[2] = wrap_angle(x[2])
        x[3] = np.clip(x[3], lim.half_width_min, lim.half_width_max)
        x[4] = np.clip(x[4], -lim.half_width_max, -lim.half_width_min)
        x[5] = np.clip(x[5], -lim.x_icr_max, lim.x_icr_max)
        if self._model > 6:
            x[6] = np.clip(x[6], lim.alpha_min, lim.alpha_max)
        if self.heading_bias is not None:
            x[-1] = wrap_angle(x[-1])
        self._P[:] = 0.5 * (self._P + self._P.T)
        if not (np.all(np.isfinite(self._P)) and np.all(np.isfinite(x))):
            raise EstimationError("EKF state became non-finite; check the noise configuration")
