"""``arc_increment_with_jacobian`` on batches: one increment row per twist, as ``arc_increment``.

Written for a mutant of ``kinematics/integration.py`` no test killed
(docs/testing.md): the increments stacked along the first axis instead of the
last, which only scalar inputs (the tests' until then) cannot tell apart.
"""

from __future__ import annotations

import numpy as np

from terrain_odom.kinematics.integration import arc_increment, arc_increment_with_jacobian


def test_a_batch_of_twists_gives_one_increment_row_each():
    v_x = np.array([1.0, 0.5, 0.0, -0.3])
    v_y = np.array([0.0, 0.1, 0.2, 0.0])
    omega = np.array([0.0, 0.5, -1.0, 2.0])
    inc, jac = arc_increment_with_jacobian(v_x, v_y, omega, 2.0)
    assert inc.shape == (4, 3) and jac.shape == (4, 3, 3)
    # straight at 1 m/s for 2 s: 2 m ahead; the third row turns 2 rad clockwise
    assert inc[0].tolist() == [2.0, 0.0, 0.0] and inc[2, 2] == -2.0
    for i in range(4):
        single = arc_increment(v_x[i], v_y[i], omega[i], 2.0)
        np.testing.assert_allclose(inc[i], single, rtol=0, atol=1e-15)
