"""Training segments for model identification (Baril et al., CRV 2020, section IV).

The training trajectory is cut into ``N`` distinct segments of travelled
distance ``h_t`` (:class:`Horizon`; or of a duration): consecutive windows
of :func:`~terrain_odom.evaluation.spatial_windows` (or
:func:`~terrain_odom.evaluation.time_windows`) chained end to start, never
crossing a ``segment`` change (:func:`training_windows`). :func:`segment_set`
pads them once into blocks of similar length for vectorised integration.

A log of positions and headings on different rows (a GPS and an IMU) has
segments between position fixes (``anchor="position"``) or heading rows
(``"heading"``), scored as :mod:`~terrain_odom.evaluation.sparse` scores
them: the start heading fitted to the segment's fixes, the heading change
from the heading rows around its ends (:func:`~terrain_odom.fitting.loss.residuals`).
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from terrain_odom.evaluation.sparse import heading_change
from terrain_odom.evaluation.windows import (
    Windows,
    non_overlapping,
    padded_steps,
    spatial_windows,
    time_windows,
)
from terrain_odom.kinematics.integration import relative_pose
from terrain_odom.records import WheelLog, change_runs

__all__ = [
    "DEFAULT_TRAINING_HORIZON",
    "Horizon",
    "SegmentSet",
    "SegmentBlock",
    "parse_horizon",
    "training_windows",
    "segment_set",
]

_BUCKET_ELEMENTS = 1 << 15  # max segments x steps per padded block


@dataclass(frozen=True)
class Horizon:
    """Segment length: a travelled distance (``unit == "m"``) or a duration (``"s"``)."""

    value: float
    unit: str = "m"

    def __post_init__(self) -> None:
        if self.unit not in ("m", "s"):
            raise ValueError(f"horizon unit must be 'm' or 's', got {self.unit!r}")
        if not (math.isfinite(self.value) and self.value > 0.0):
            raise ValueError(f"horizon must be a positive number, got {self.value}")

    def __str__(self) -> str:
        return f"{self.value:g}{self.unit}"

    def windows(self, log: WheelLog, anchor: str = "pose") -> Windows:
        """All windows of this horizon in ``log`` (overlapping, one per ``anchor`` row)."""
        if self.unit == "m":
            return spatial_windows(log, self.value, anchor=anchor)
        return time_windows(log, self.value, anchor=anchor)


DEFAULT_TRAINING_HORIZON = Horizon(2.0, "m")  # Baril et al.'s h_t


def parse_horizon(text: str | float) -> Horizon:
    """Parse ``"2m"``, ``"1.5 s"`` or a bare number of metres.

    Raises
    ------
    ValueError
        Naming the text and the expected form.

    Examples
    --------
    >>> parse_horizon("2m"), parse_horizon("1.5 s"), parse_horizon(3)
    (Horizon(value=2.0, unit='m'), Horizon(value=1.5, unit='s'), Horizon(value=3.0, unit='m'))
    """
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        return Horizon(float(text), "m")
    match = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*([ms]?)\s*", str(text))
    if match is None or float(match.group(1)) <= 0.0:
        raise ValueError(
            f"horizon {text!r} is not a positive distance or duration like '2m' or '2s'"
        )
    return Horizon(float(match.group(1)), match.group(2) or "m")


def training_windows(
    log: WheelLog, horizon: Horizon, terrain: str | None = None, anchor: str = "pose"
) -> Windows:
    """Distinct training segments of a log: chained windows of ``horizon``.

    Parameters
    ----------
    log : WheelLog
        Log with pose measurements.
    horizon : Horizon
        Segment length ``h_t`` (m) or duration (s).
    terrain : str, optional
        Keep only segments that lie entirely on this terrain label (needs a
        terrain column); segments never cross a terrain change then.

    Returns
    -------
    Windows
        Non-overlapping windows, each inside one ``segment`` of the log.
    """
    if terrain is None:
        return non_overlapping(horizon.windows(log, anchor))
    if log.terrain is None:
        raise ValueError(f"{log.source}: no terrain column, cannot select terrain {terrain!r}")
    labels = np.asarray(log.terrain)
    # split the log at terrain changes as well as at segment changes
    split = dataclasses.replace(log, segment=change_runs(log.segment, labels))
    w = non_overlapping(horizon.windows(split, anchor))
    keep = labels[w.start] == terrain
    return Windows(start=w.start[keep], end=w.end[keep], length=w.length[keep])


@dataclass(frozen=True)
class SegmentBlock:
    """Padded speeds and durations of segments of similar length, shape (W, K).

    ``target``: the measured end pose in the segment's start frame, or for
    segments without a start heading (``fixes`` set) only its heading change
    (NaN without headings); ``fixes`` (W, K + 1): where the pose before each
    step (and the end, last) has a position fix; ``measured`` (W, K + 1, 2):
    each fix's displacement from the start fix in the world frame, m (set
    with ``fixes``).
    """

    v_l: np.ndarray
    v_r: np.ndarray
    dt: np.ndarray
    target: np.ndarray
    fixes: np.ndarray | None = None
    measured: np.ndarray | None = None


@dataclass(frozen=True)
class SegmentSet:
    """Training segments of one or more logs, padded for vectorised integration.

    Attributes
    ----------
    blocks : tuple
        Segments grouped by length (padding < 2x, bounded memory).
    count : int
        Number of segments ``N``.
    length : float
        Total measured path length of the segments, m.
    duration : float
        Total duration of the segments, s.
    antenna : tuple of 2 floats
        Where the position sensor is in the robot frame, m (segments between fixes).
    """

    blocks: tuple[SegmentBlock, ...]
    count: int
    length: float
    duration: float
    antenna: tuple[float, float] = (0.0, 0.0)


def segment_set(
    logs: Sequence[WheelLog],
    windows: Sequence[Windows],
    *,
    anchor: str | Sequence[str] = "pose",
    antenna: Sequence[float] = (0.0, 0.0),
) -> SegmentSet:
    """Pad the training segments of some logs once, for all loss evaluations.

    Parameters
    ----------
    logs : sequence of WheelLog
        The training logs.
    windows : sequence of Windows
        Their segments (e.g. from :func:`training_windows`), one per log.
    anchor : {"pose", "position", "heading"} or a sequence of them, optional
        What the segments run between (as given to :func:`training_windows`),
        for all the logs or one per log.
    antenna : sequence of 2 floats, optional
        Where the position sensor is in the robot frame, m (``pose_sensor``).

    Returns
    -------
    SegmentSet
    """
    blocks: list[SegmentBlock] = []
    anchors = [anchor] * len(logs) if isinstance(anchor, str) else list(anchor)
    for full_log, full_win, kind in zip(logs, windows, anchors, strict=True):
        log, win = _merge_constant_steps(full_log, full_win, keep_fixes=kind == "position")
        n_steps = win.end - win.start
        if n_steps.size == 0:
            continue
        bucket = np.ceil(np.log2(n_steps)).astype(int)
        for b in np.unique(bucket):
            idx = np.flatnonzero(bucket == b)
            per_block = max(1, _BUCKET_ELEMENTS >> int(b))
            for i in range(0, idx.size, per_block):
                blocks.append(_block(log, win, idx[i : i + per_block], kind))
    count = sum(b.target.shape[0] for b in blocks)
    length = float(sum(w.length.sum() for w in windows))
    duration = float(sum(b.dt.sum() for b in blocks))
    a_x, a_y = (float(v) for v in antenna)
    return SegmentSet(tuple(blocks), count, length, duration, (a_x, a_y))


def _block(log: WheelLog, win: Windows, part: np.ndarray, anchor: str) -> SegmentBlock:
    """Pad the segments ``part`` of ``win`` into one block."""
    rows, valid, dt = padded_steps(log, win, part)
    v_l, v_r = np.where(valid, log.v_l[rows], 0.0), np.where(valid, log.v_r[rows], 0.0)
    start, end = win.start[part], win.end[part]
    if anchor == "pose":
        return SegmentBlock(v_l, v_r, dt, relative_pose(log.pose[start], log.pose[end]))
    target = np.zeros((part.size, 3))
    target[:, :2] = np.nan  # no start heading: the fixes are compared turned (loss.residuals)
    target[:, 2] = heading_change(log, start, end)
    at = np.concatenate([rows, end[:, None]], axis=1)
    fixes = np.concatenate([valid, np.ones((part.size, 1), bool)], axis=1) & log.has_position[at]
    measured = np.where(fixes[..., None], log.pose[at, :2] - log.pose[start, None, :2], 0.0)
    return SegmentBlock(v_l, v_r, dt, target, fixes, measured)


def _merge_constant_steps(
    log: WheelLog, windows: Windows, *, keep_fixes: bool = False
) -> tuple[WheelLog, Windows]:
    """Merge consecutive steps with equal track speeds inside each window.

    Every model's twist depends on the current speeds only, and a constant
    twist integrates exactly over the merged duration, so the predicted end
    poses are unchanged; the logs hold each wheel reading for ~5 rows, so this
    divides the integration work accordingly. Keeps the window start and end
    rows and every row where the speeds change inside a window (and with
    ``keep_fixes`` every position fix inside one: segments between fixes
    are compared at each).
    """
    n = len(log)
    inside = np.zeros(n + 1, dtype=int)
    np.add.at(inside, windows.start, 1)
    np.add.at(inside, windows.end, -1)
    in_window = np.cumsum(inside)[:n] > 0
    changed = np.r_[True, (log.v_l[1:] != log.v_l[:-1]) | (log.v_r[1:] != log.v_r[:-1])]
    keep = in_window & (changed | (log.has_position if keep_fixes else False))
    keep[windows.start] = True
    keep[windows.end] = True
    rows = np.flatnonzero(keep)
    merged = WheelLog(
        log.t[rows], log.v_l[rows], log.v_r[rows], log.pose[rows], None, log.segment[rows],
        log.source,
    )  # fmt: skip
    where = np.searchsorted(rows, [windows.start, windows.end])
    return merged, Windows(start=where[0], end=where[1], length=windows.length)
