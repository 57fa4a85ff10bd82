"""The pose measurement as the filters see it: prediction, Jacobian, what was used.

The sensors' mounting (antenna lever arm, heading offset) and what they
measure at a robot pose are :mod:`terrain_odom.kinematics.mounting`; a
measurement row holds any subset of the antenna's ``x, y`` and the sensor's
``yaw``. :func:`measurement` gives the prediction ``h(x)`` of the measured
components over a filter's state and its Jacobian ``H`` (tested against
finite differences); :func:`chord_turn` what positions alone measure of two
pose changes (the slip EKF's GPS-only update); :func:`measured_rows` which
components of a row count; :class:`PoseUse` what became of each of them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from terrain_odom.kinematics import wrap_angle
from terrain_odom.kinematics.mounting import Mounting, rotation_with_derivative, sensor_pose

__all__ = [
    "GATED",
    "PoseUse",
    "chord_turn",
    "measurement",
    "measured_rows",
]

_YAW = 2


def measured_rows(z: ArrayLike) -> np.ndarray:
    """Return the indices (into ``x, y, yaw``) of the finite components of ``z``.

    A position is measured only as a pair: ``x`` without ``y`` (or the
    reverse) leaves both out.

    Examples
    --------
    >>> measured_rows([1.0, float("nan"), 0.3]).tolist()
    [2]
    """
    finite = np.isfinite(np.asarray(z, dtype=float))
    if not (finite[0] and finite[1]):
        finite[:2] = False
    return np.flatnonzero(finite)


def measurement(
    state: ArrayLike, rows: ArrayLike, mounting: Mounting
) -> tuple[np.ndarray, np.ndarray]:
    """Predict the measured components ``rows`` of a pose sensor, and the Jacobian.

    Parameters
    ----------
    state : array_like, shape (n,)
        Filter state starting with the robot's ``x, y, yaw``.
    rows : array_like of int
        Measured components (0: x, 1: y, 2: yaw), ascending.
    mounting : Mounting
        Antenna lever arm and heading offset.

    Returns
    -------
    h : ndarray, shape (len(rows),)
        Predicted antenna position and sensor heading (wrapped).
    H : ndarray, shape (len(rows), n)
        ``d h / d state``.

    Examples
    --------
    >>> h, H = measurement([1.0, 2.0, np.pi / 2, 0.3], [0, 1], Mounting(0.5, 0.0, 0.0))
    >>> h.round(6).tolist(), H[:, 2].round(6).tolist()
    ([1.0, 2.5], [-0.5, 0.0])
    """
    s = np.asarray(state, dtype=float)
    rows = np.asarray(rows, dtype=int)
    _, d_rot = rotation_with_derivative(s[_YAW])
    full_h = sensor_pose(s[:3], mounting)
    full_H = np.zeros((3, s.size))  # noqa: N806 - the usual symbol
    full_H[[0, 1, 2], [0, 1, 2]] = 1.0
    full_H[:2, _YAW] = d_rot @ mounting.antenna
    return full_h[rows], full_H[rows]


def _chord(change: np.ndarray, jac: np.ndarray, arm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return the antenna's displacement over a pose ``change`` (start frame) and its Jacobian."""
    rot, d_rot = rotation_with_derivative(change[_YAW])
    return change[:2] + rot @ arm - arm, jac[:2] + np.outer(d_rot @ arm, jac[_YAW])


def chord_turn(
    first: ArrayLike,
    j_first: ArrayLike,
    second: ArrayLike,
    j_second: ArrayLike,
    antenna: ArrayLike,
) -> tuple[np.ndarray, np.ndarray]:
    """Predict two consecutive antenna chords as a GPS alone sees them: length and turn.

    Without a heading, positions fix the path only up to a rotation; what
    they measure of two consecutive pose changes is the length of the
    antenna's second chord and the angle from the first chord to the second.

    Parameters
    ----------
    first, second : array_like, shape (3,)
        Consecutive pose changes ``dx, dy, dyaw``, each in its start frame.
    j_first, j_second : array_like, shape (3, n)
        Their Jacobians with respect to the parameters.
    antenna : array_like, shape (2,)
        Position sensor in the robot frame, m.

    Returns
    -------
    h : ndarray, shape (2,)
        Length of the second chord (m), and turn from the first chord's
        direction to the second's (rad, wrapped).
    H : ndarray, shape (2, n)
        ``d h / d params``.

    Examples
    --------
    >>> quarter = [1.0, 1.0, np.pi / 2]  # a quarter circle of radius 1, to the left
    >>> h, _ = chord_turn(quarter, np.zeros((3, 1)), quarter, np.zeros((3, 1)), [0.0, 0.0])
    >>> h.round(6).tolist()  # chord sqrt(2); the chords turn by the quarter
    [1.414214, 1.570796]
    """
    arm = np.asarray(antenna, dtype=float)
    first, second = np.asarray(first, dtype=float), np.asarray(second, dtype=float)
    c1, j1 = _chord(first, np.asarray(j_first, dtype=float), arm)
    c2, j2 = _chord(second, np.asarray(j_second, dtype=float), arm)
    l1, l2 = float(c1 @ c1), float(c2 @ c2)
    h = np.array(
        [
            np.sqrt(l2),
            wrap_angle(first[_YAW] + np.arctan2(c2[1], c2[0]) - np.arctan2(c1[1], c1[0])),
        ]
    )
    d_turn = (
        np.asarray(j_first, dtype=float)[_YAW]
        + (c2[0] * j2[1] - c2[1] * j2[0]) / l2
        - (c1[0] * j1[1] - c1[1] * j1[0]) / l1
    )
    return h, np.vstack([c2 @ j2 / np.sqrt(l2), d_turn])


_UNPAIRED = "x without y (or y without x)"
GATED = "rejected by the gate"
"""Why a component was dropped by the ICR EKF's chi-square gate (:class:`PoseUse`)."""


@dataclass
class PoseUse:
    """What became of the measured pose components of a run.

    Each measured row counts once per component it has: ``position`` (an
    ``x, y`` pair) and ``heading`` (``yaw``).

    Attributes
    ----------
    position, heading : int
        Components measured.
    used_position, used_heading : int
        Fused by the filter (or used as the anchor of a later update).
    dropped : dict of str to int
        Components not used, by reason (``"position: ..."``, ``"heading: ..."``;
        ``"position: rejected by the gate"``: the innovation beyond the
        chi-square gate, see :data:`GATED`).
    reacquired_position, reacquired_heading : int
        Components beyond the gate fused all the same, with the pose
        variance grown (the filter re-acquired after rejections in a row).
    """

    position: int = 0
    heading: int = 0
    used_position: int = 0
    used_heading: int = 0
    dropped: dict[str, int] = field(default_factory=dict)
    reacquired_position: int = 0
    reacquired_heading: int = 0

    def measured(self, rows: Sequence[int] | np.ndarray, z: np.ndarray) -> None:
        """Count the components of one measurement ``z`` (``rows``: its usable ones)."""
        self.position += int(0 in rows)
        self.heading += int(_YAW in rows)
        if 0 not in rows and np.isfinite(z[:2]).any():
            self.drop("position", _UNPAIRED)

    def fused(self, z: np.ndarray) -> None:
        """Count the rows of ``z`` (B, 3) as :meth:`measured`, and each usable component used.

        What an anchored filter does with a stretch of pose rows: it fuses
        every pair ``x, y`` and every ``yaw`` (rows with no finite component
        count nothing).
        """
        finite = np.isfinite(z)
        pair = finite[:, 0] & finite[:, 1]
        positions, headings = int(np.count_nonzero(pair)), int(np.count_nonzero(finite[:, _YAW]))
        self.position += positions
        self.heading += headings
        self.used_position += positions
        self.used_heading += headings
        unpaired = int(np.count_nonzero(finite[:, 0] != finite[:, 1]))
        if unpaired:
            self.drop("position", _UNPAIRED, unpaired)

    def used(self, what: str) -> None:
        """Count one ``position`` or ``heading`` component as used."""
        if what == "position":
            self.used_position += 1
        else:
            self.used_heading += 1

    def gated(self, counts: Sequence[float]) -> None:
        """Take the gate's counts (rejected positions, headings, re-acquired ones) since counted used.

        The rejected components were counted used (:meth:`used`, :meth:`fused`):
        they move to :attr:`dropped` as :data:`GATED`.
        """
        rejected_position, rejected_heading, again_position, again_heading = map(int, counts)
        for what, rejected in (("position", rejected_position), ("heading", rejected_heading)):
            if rejected:
                setattr(self, f"used_{what}", getattr(self, f"used_{what}") - rejected)
                self.drop(what, GATED, rejected)
        self.reacquired_position += again_position
        self.reacquired_heading += again_heading

    def drop(self, what: str, why: str, count: int = 1) -> None:
        """Count ``count`` ``position`` or ``heading`` components dropped because ``why``."""
        key = f"{what}: {why}"
        self.dropped[key] = self.dropped.get(key, 0) + count

    def summary(self) -> str:
        """One line: components used of measured, and the dropped ones by reason.

        Examples
        --------
        >>> use = PoseUse(position=10, used_position=8, dropped={"position: before a heading": 2})
        >>> use.summary()
        'position 8 of 10 used, heading 0 of 0 (dropped: 2 position: before a heading)'
        >>> PoseUse(position=989, used_position=960, dropped={"position: " + GATED: 29}).summary()
        'position 960 of 989 used, 29 rejected by the gate, heading 0 of 0'
        """
        parts = []
        for what, used in (("position", " used"), ("heading", "")):
            part = f"{what} {getattr(self, f'used_{what}')} of {getattr(self, what)}{used}"
            rejected = self.dropped.get(f"{what}: {GATED}", 0)
            again = getattr(self, f"reacquired_{what}")
            part += f", {rejected} {GATED}" if rejected else ""
            part += f" ({again} re-acquired)" if again else ""
            parts.append(part)
        line = ", ".join(parts)
        others = {k: n for k, n in self.dropped.items() if not k.endswith(GATED)}
        if others:
            line += " (dropped: " + ", ".join(f"{n} {k}" for k, n in others.items()) + ")"
        return line
