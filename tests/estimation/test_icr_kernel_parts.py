"""Parts of the ICR EKF's kernels the filters' tests cannot see: exact arc coefficients, flags.

The kernels are held to their numpy reference at 1e-12, which shares the
arc's series: a coefficient of its last terms changed moves a step by less
than that (mutation testing, docs/testing.md). Here the coefficients are
held to their exact values (Taylor sums in rational arithmetic) within the
truncation of the series. ``step_jacobian`` writes all of ``F``, also the
entries its callers skip. ``constrain`` reports a covariance gone
non-finite even where the state is finite.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest

from terrain_odom.estimation import _kernels
from terrain_odom.estimation.icr_model import icr_step_with_jacobian


def _exact_arc(phi: float) -> tuple[float, float, float, float]:
    """``sin(phi)/phi, (1 - cos(phi))/phi`` and their derivatives, from exact Taylor sums."""
    f = Fraction(phi)
    a = b = da = db = Fraction(0)
    for k in range(30):  # |phi| <= 2: the terms left are below 1e-60
        sign = -1 if k % 2 else 1
        a += Fraction(sign * f ** (2 * k), math.factorial(2 * k + 1))
        b += Fraction(sign * f ** (2 * k + 1), math.factorial(2 * k + 2))
        da += Fraction(sign * 2 * k * f ** (2 * k - 1), math.factorial(2 * k + 1)) if k else 0
        db += Fraction(sign * (2 * k + 1) * f ** (2 * k), math.factorial(2 * k + 2))
    return float(a), float(b), float(da), float(db)


@pytest.mark.parametrize("phi", [0.0, 1e-4, 0.004, -0.004, 0.0099, -0.0099])
def test_the_arc_series_is_exact_to_its_truncation(phi):
    """Below 1e-2 the kernel sums A to phi^4, B to phi^5, dA to phi^3, dB to phi^4."""
    truncation = [phi**6 / 5040, abs(phi) ** 7 / 40320, abs(phi) ** 5 / 840, phi**6 / 5760]
    got, exact = _kernels._arc(phi), _exact_arc(phi)
    for name, g, e, cut in zip(("A", "B", "dA", "dB"), got, exact, truncation, strict=True):
        assert abs(g - e) <= 1.01 * cut + 4e-16 * abs(e), name


@pytest.mark.parametrize("phi", [0.0101, -0.02, 0.3, -2.0])
def test_the_arc_closed_form_is_exact(phi):
    got, exact = _kernels._arc(phi), _exact_arc(phi)
    np.testing.assert_allclose(got, exact, rtol=1e-12, atol=1e-13)


@pytest.mark.parametrize("n", [6, 7])
@pytest.mark.parametrize(
    ("v_l", "v_r", "dt"), [(0.4, 1.3, 0.05), (1.0, 1.0, 0.1), (-1.0, 1.0, 0.2)]
)
def test_step_jacobian_writes_the_whole_f_of_the_icr_step(n, v_l, v_r, dt):
    """Every entry of ``jac`` is written: the identity and zeros the filters skip, too."""
    x = np.array([1.0, -2.0, 3.0, 0.9, -0.8, 0.1, 0.95])[:n]
    want_x, want_f = icr_step_with_jacobian(x, v_l, v_r, dt)
    got, jac = x.copy(), np.full((n, n), np.nan)
    _kernels.step_jacobian(got, v_l, v_r, dt, jac)
    np.testing.assert_allclose(got, want_x, rtol=0, atol=1e-14)
    np.testing.assert_allclose(jac, want_f, rtol=1e-12, atol=1e-14)


LIMITS = np.array([0.1, 2.0, 1.0, 0.5, 1.5])


@pytest.mark.parametrize("where", ["state", "covariance", "neither"])
def test_constrain_reports_a_non_finite_state_or_covariance(where):
    x = np.array([0.0, 0.0, 0.0, 0.5, -0.5, 0.0, 1.0])
    p = np.eye(7)
    if where == "state":
        x[0] = math.nan
    elif where == "covariance":
        p[1, 4] = math.inf
    assert _kernels.constrain(x, p, LIMITS, 7) == (where == "neither")
