"""The ICR EKF's kernels equal the filterpy reference on every path of an update.

Mutation testing of the kernels (docs/testing.md) found branches the kernel
tests never take: they run without a heading bias, with headings not gated,
positions seldom rejected and alpha off only where every row has a position.
These scripted steps take each branch (alpha on and off,
a heading bias on and off; a position or a heading rejected alone or both
at once, re-acquired after rejections in a row or after seconds of them,
with and without the pose variances grown; heading-only, position-only,
``x`` without ``y`` and empty rows) and compare state, covariance, NIS and
the gate's counts with :class:`FilterpyIcrEkf` (its own gate, numpy and
filterpy) after every step, one update at a time and as a stretch of rows.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from terrain_odom.config import EkfConfig, PoseGate
from terrain_odom.estimation import IcrEkf, _kernels
from terrain_odom.estimation.icr_ekf_reference import FilterpyIcrEkf
from terrain_odom.estimation.icr_model import HeadingBias
from terrain_odom.kinematics.mounting import Mounting

from .conftest import TOLERANCE

NAN = math.nan
MOUNTING = Mounting(-0.4, 0.2, 0.3)  # antenna behind and left of the centre, heading offset
STEPS = [  # (what, offset of z from the predicted measurement: x, y, yaw; in m and rad or in sd)
    ("both", (0.01, -0.01, 0.005), "m"),
    ("heading only", (NAN, NAN, 0.004), "m"),
    ("position only", (-0.01, 0.02, NAN), "m"),
    ("x without y: heading only", (0.01, NAN, -0.003), "m"),
    ("nothing", (NAN, NAN, NAN), "m"),
    ("position jump, heading fused", (30.0, -20.0, 0.002), "m"),
    ("heading jump, position fused", (0.01, 0.0, 2.5), "m"),
    ("position jump again", (30.0, -20.0, NAN), "m"),
    ("third position jump", (30.0, -20.0, 0.001), "m"),
    ("heading jump", (NAN, NAN, 2.5), "m"),
    ("heading jump again", (NAN, NAN, 2.5), "m"),
    ("third heading jump", (0.01, 0.01, 2.5), "m"),
    ("both jump", (-25.0, 15.0, -2.0), "m"),
    ("both jump again", (-25.0, 15.0, -2.0), "m"),
    ("both jump a third time", (-25.0, 15.0, -2.0), "m"),
    ("both jump a fourth time", (-25.0, 15.0, -2.0), "m"),
    ("beyond the bounds, within ten", (6.0, 0.0, 6.0), "sd"),
    ("again", (6.0, 0.0, 6.0), "sd"),
    ("and again", (6.0, 0.0, 6.0), "sd"),
    ("and a fourth time", (6.0, 0.0, 6.0), "sd"),
    ("heading only after it", (NAN, NAN, 0.01), "m"),
    ("both", (0.0, 0.01, 0.0), "m"),
]


def _filters(alpha: bool, bias: bool, gate: PoseGate) -> tuple[IcrEkf, FilterpyIcrEkf]:
    config = dataclasses.replace(EkfConfig(), estimate_alpha=alpha, gate=gate)
    heading_bias = HeadingBias(sigma=0.2, tau=25.0) if bias else None
    fast = IcrEkf(config, mounting=MOUNTING, heading_bias=heading_bias)
    return fast, FilterpyIcrEkf(config, mounting=MOUNTING, heading_bias=heading_bias)


def _predicted(ekf: IcrEkf) -> np.ndarray:
    """Return the measurement the filter expects: antenna position, heading + offset + bias."""
    x, y, yaw = ekf.pose
    c, s = math.cos(yaw), math.sin(yaw)
    arm_x, arm_y = MOUNTING.antenna_x, MOUNTING.antenna_y
    heading = yaw + MOUNTING.heading_offset + ekf.bias
    return np.array([x + c * arm_x - s * arm_y, y + s * arm_x + c * arm_y, heading])


def _sd(ekf: IcrEkf) -> np.ndarray:
    """Each component's innovation standard deviation (the heading's with the bias's share)."""
    r, p = ekf.config.sigma_r, ekf.P
    var = p.diagonal()[:3] + np.array([r.x, r.y, r.yaw]) ** 2
    if ekf.heading_bias is not None:
        var[2] += p[-1, -1] + 2.0 * p[2, -1]
    return np.sqrt(var)


def _assert_same(fast: IcrEkf, slow: IcrEkf, what: str) -> None:
    np.testing.assert_allclose(fast.x, slow.x, rtol=0, atol=TOLERANCE, err_msg=what)
    np.testing.assert_allclose(fast.P, slow.P, rtol=0, atol=TOLERANCE, err_msg=what)
    np.testing.assert_array_equal(fast.gating, slow.gating, err_msg=what)


GATES = {
    "after rejections in a row": PoseGate(headings=True, reacquire_after=2, reacquire=1e9),
    "after seconds of them": PoseGate(headings=True, reacquire_after=10**6, reacquire=0.12),
}


@pytest.mark.parametrize("gate", list(GATES), ids=list(GATES))
@pytest.mark.parametrize("bias", [False, True], ids=["no bias", "bias"])
@pytest.mark.parametrize("alpha", [True, False], ids=["alpha", "no alpha"])
def test_every_path_of_an_update_equals_filterpy(alpha, bias, gate):
    fast, slow = _filters(alpha, bias, GATES[gate])
    rng = np.random.default_rng(5)
    t, speeds, z_rows = [], [], []
    clock = 0.0
    for what, offset, unit in STEPS:
        v_l, v_r = rng.uniform(0.2, 1.2, 2)
        for ekf in (fast, slow):
            ekf.predict(v_l, v_r, 0.05)
        clock += 0.05
        z = _predicted(slow) + np.array(offset) * (_sd(slow) if unit == "sd" else 1.0)
        nis = [ekf.update(z) for ekf in (fast, slow)]
        assert nis[0] == pytest.approx(nis[1], rel=1e-12, nan_ok=True), what
        _assert_same(fast, slow, what)
        t.append(clock)
        speeds.append((v_l, v_r))
        z_rows.append(z)
    counts = fast.gating[4:]  # positions, headings rejected; positions, headings re-acquired
    assert counts.min() >= 1.0, counts  # every kind happened
    assert fast.last_nis == pytest.approx(slow.last_nis, rel=1e-12)
    # the same rows as one stretch: the speeds of each row are held until the next
    fast, slow = _filters(alpha, bias, GATES[gate])
    v = np.array(speeds)
    since = (0.0, *v[0])
    held_v, held_t = (v[1:, 0], v[1:, 1]), np.array(t[1:])
    first = np.array(t[:1]), (v[:1, 0], v[:1, 1]), np.array(z_rows[:1])
    for ekf in (fast, slow):  # the first row's speeds are held from t = 0
        ekf.run_rows(since, *first)
    rows = [
        ekf.run_rows((t[0], *v[0]), held_t, held_v, np.array(z_rows[1:])) for ekf in (fast, slow)
    ]
    np.testing.assert_allclose(rows[0][0], rows[1][0], rtol=0, atol=TOLERANCE)
    np.testing.assert_allclose(rows[0][1], rows[1][1], rtol=0, atol=TOLERANCE)
    assert rows[0][2] == rows[1][2] > 0
    _assert_same(fast, slow, "stretch")


LIMITS = np.array([0.1, 2.0, 1.0, 0.5, 1.5])  # half widths, |x_icr|, alpha


@pytest.mark.parametrize("component", ["position", "heading"])
def test_a_component_exactly_at_its_gate_bound_is_fused(component):
    """The gate rejects beyond the bound only: ``S = 1`` exactly, an innovation of 2, a NIS of 4."""
    z = np.array([2.0, 0.0, NAN] if component == "position" else [NAN, NAN, 2.0])
    kind = 0 if component == "position" else 1
    for nudge, fused in [(0.0, True), (1e-9, False)]:
        x = np.array([0.0, 0.0, 0.0, 0.5, -0.5, 0.0, 1.0])
        p = np.diag([0.75, 0.75, 0.75, 0.1, 0.1, 0.1, 0.1])
        gating = np.array([NAN, NAN, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
        gate = np.array([4.0, 4.0, 10.0, 1e9])  # NIS bounds; re-acquired after ten rejections
        measured = z + np.array([nudge, 0.0, 0.0] if kind == 0 else [0.0, 0.0, nudge])
        nis, finite = _kernels.icr_update(
            x, p, measured, 0.25 * np.eye(3), np.zeros(3), LIMITS, gate, gating, 0.0, np.empty(0)
        )
        assert finite
        if fused:
            assert nis == 4.0 and not gating[4:].any()
        else:
            assert math.isnan(nis) and gating[4 + kind] == 1.0 and gating[kind] == 0.0


def test_a_component_rejected_for_exactly_reacquire_seconds_is_fused():
    """Rejected at 0.25 s and 0.5 s, re-acquired at 0.75 s: all rejected for ``reacquire`` = 0.5 s."""
    gate = PoseGate(reacquire_after=10**6, reacquire=0.5)
    ekf = IcrEkf(dataclasses.replace(EkfConfig(), gate=gate))
    jump = [50.0, 0.0, NAN]
    nis = []
    for _ in range(3):
        ekf.predict(0.0, 0.0, 0.25)  # standing; the clock advances by exact binary fractions
        nis.append(ekf.update(jump))
    assert math.isnan(nis[0]) and math.isnan(nis[1]) and nis[2] > 100.0
    assert ekf.gating[4:].tolist() == [2.0, 0.0, 1.0, 0.0]
