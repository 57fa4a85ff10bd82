"""Kalman arithmetic both EKFs' kernels share, compiled by numba with them.

Small dense matrices in scalar loops (numba's ``@`` loads SciPy's BLAS, and
numpy's per-call overhead on 2x2 to 7x7 arrays costs more than the sums):
the innovation covariance, filterpy's gain ``K = P H^T S^-1`` and Joseph-form
covariance update, the inverse of ``S``, symmetrising ``P``, the standard
deviations, and the angle wrap. The ICR EKF's kernels
(:mod:`~terrain_odom.estimation._kernels`) and the slip EKF's
(:mod:`~terrain_odom.estimation._slip_kernels`) call them; they join the
switch of :mod:`~terrain_odom.estimation._kernel_switch` (no public kernel of
their own: their callers' are counted). numba's disk cache keys a function on
its own file only: after editing one of these, touch the files of the kernels
that call it (or clear ``__pycache__``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from terrain_odom.estimation._kernel_switch import register

__all__ = [
    "KERNELS",
    "gain_from",
    "innovation_covariance",
    "inverse",
    "joseph",
    "kalman_gain",
    "matmul",
    "std_into",
    "symmetrise",
    "wrap",
]

_TWO_PI = 2.0 * math.pi


def wrap(angle: float) -> float:
    """:func:`~terrain_odom.kinematics.wrap_angle` of one angle."""
    if -math.pi < angle <= math.pi:
        return angle
    return math.pi - np.mod(math.pi - angle, _TWO_PI)


def matmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Return ``a @ b`` of small square matrices, in loops (numba's ``@`` loads SciPy's BLAS).

    Zeros of ``a`` are skipped: the sums are those of the full product, bit for bit
    (a finite ``b``), at the cost of the nonzero terms (``I - K H`` is mostly the identity).
    """
    n = a.shape[0]
    out = np.zeros((n, n))
    for i in range(n):
        for k in range(n):
            aik = a[i, k]
            if aik != 0.0:
                for j in range(n):
                    out[i, j] += aik * b[k, j]
    return out


def symmetrise(p: np.ndarray) -> None:
    """``P = (P + P^T) / 2`` in place."""
    n = p.shape[0]
    for i in range(n):
        for j in range(i + 1, n):
            m = 0.5 * (p[i, j] + p[j, i])
            p[i, j] = m
            p[j, i] = m


def inverse(s: np.ndarray) -> np.ndarray:
    """Inverse of a small non-singular matrix (Gauss-Jordan, partial pivoting)."""
    m = s.shape[0]
    a = s.copy()
    inv = np.eye(m)
    for col in range(m):
        pivot = col
        for row in range(col + 1, m):
            if abs(a[row, col]) > abs(a[pivot, col]):
                pivot = row
        for k in range(m):
            a[col, k], a[pivot, k] = a[pivot, k], a[col, k]
            inv[col, k], inv[pivot, k] = inv[pivot, k], inv[col, k]
        scale = 1.0 / a[col, col]
        for k in range(m):
            a[col, k] *= scale
            inv[col, k] *= scale
        for row in range(m):
            if row != col:
                f = a[row, col]
                for k in range(m):
                    a[row, k] -= f * a[col, k]
                    inv[row, k] -= f * inv[col, k]
    return inv


def innovation_covariance(
    p: np.ndarray, jac: np.ndarray, rows: np.ndarray, r: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Return ``P H^T`` and ``S = H P H^T + R`` (``R`` of ``rows``)."""
    n, m = p.shape[0], rows.size
    pht = np.zeros((n, m))
    for i in range(n):
        for j in range(m):
            for k in range(n):
                pht[i, j] += p[i, k] * jac[j, k]
    s = np.empty((m, m))
    for i in range(m):
        for j in range(m):
            acc = r[rows[i], rows[j]]
            for k in range(n):
                acc += jac[i, k] * pht[k, j]
            s[i, j] = acc
    return pht, s


def kalman_gain(
    p: np.ndarray, jac: np.ndarray, rows: np.ndarray, r: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Return the Kalman gain ``K = P H^T S^-1`` and ``S^-1``, ``S = H P H^T + R`` (``R`` of ``rows``)."""
    return gain_from(*innovation_covariance(p, jac, rows, r))


def gain_from(pht: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return the Kalman gain ``K = P H^T S^-1`` and ``S^-1`` from ``P H^T`` and ``S``."""
    n, m = pht.shape
    si = inverse(s)
    k_gain = np.zeros((n, m))
    for i in range(n):
        for j in range(m):
            for k in range(m):
                k_gain[i, j] += pht[i, k] * si[k, j]
    return k_gain, si


def joseph(
    p: np.ndarray, k_gain: np.ndarray, jac: np.ndarray, rows: np.ndarray, r: np.ndarray
) -> None:
    """Set ``P = (I - K H) P (I - K H)^T + K R K^T`` in place (``R`` of ``rows``)."""
    n, m = k_gain.shape
    i_kh = np.eye(n)
    for k in range(m):  # H is sparse (ICR EKF): its zeros skipped, the same sums
        for j in range(n):
            h_kj = jac[k, j]
            if h_kj != 0.0:
                for i in range(n):
                    i_kh[i, j] -= k_gain[i, k] * h_kj
    left = matmul(i_kh, p)
    kr = np.zeros((n, m))
    for i in range(n):
        for j in range(m):
            for k in range(m):
                kr[i, j] += k_gain[i, k] * r[rows[k], rows[j]]
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                c = i_kh[j, k]
                if c != 0.0:
                    acc += left[i, k] * c
            noise = 0.0
            for k in range(m):
                noise += kr[i, k] * k_gain[j, k]
            p[i, j] = acc + noise


def std_into(p: np.ndarray, out: np.ndarray) -> None:
    """Write the standard deviations ``sqrt(max(diag(P), 0))`` into ``out`` (n,)."""
    for i in range(p.shape[0]):
        out[i] = math.sqrt(max(p[i, i], 0.0))


KERNELS: dict[str, Callable[..., Any]] = {
    name: globals()[name]
    for name in ("wrap", "matmul", "symmetrise", "inverse", "innovation_covariance")
    + ("kalman_gain", "gain_from", "joseph", "std_into")
}
"""These kernels as Python by name, for the modules whose kernels call them (see :func:`register`)."""
register(globals(), KERNELS, ())
