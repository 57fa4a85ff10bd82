"""Training segments for model identification (Baril et al., CRV 2020, section IV).

The training trajectory is cut into ``N`` distinct segments of travelled
distance ``h_t`` (:class:`Horizon`; or of a duration): consecutive windows
of :func:`~terrain_odom.evaluation.spatial_windows` (or
:func:`~terrain_odom.evaluation.time_windows`) chained end to start, never
crossing a ``segment`` change (:func:`training_windows`). :func:`segment_set`
pads them once into blocks of similar length for vectorised integration.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

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

    def windows(self, log: WheelLog) -> Windows:
        """All windows of this horizon in ``log`` (overlapping, one per pose row)."""
        if self.unit == "m":
            return spatial_windows(log, self.value)
        return time_windows(log, self.value)


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


def training_windows(log: WheelLog, horizon: Horizon, terrain: str | None = None) -> Windows:
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
        return non_overlapping(horizon.windows(log))
    if log.terrain is None:
        raise ValueError(f"{log.source}: no terrain column, cannot select terrain {terrain!r}")
    labels = np.asarray(log.terrain)
    # split the log at terrain changes as well as at segment changes
    split = dataclasses.replace(log, segment=change_runs(log.segment, labels))
    w = non_overlapping(horizon.windows(split))
    keep = labels[w.start] == terrain
    return Windows(start=w.start[keep], end=w.end[keep], length=w.length[keep])


@dataclass(frozen=True)
class _Block:
    """Padded speeds and durations of segments of similar length, shape (W, K)."""

    v_l: np.ndarray
    v_r: np.ndarray
    dt: np.ndarray
    target: np.ndarray  # (W, 3) measured end pose in the segment's start frame


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
    """

    blocks: tuple[_Block, ...]
    count: int
    length: float
    duration: float


def segment_set(logs: Sequence[WheelLog], windows: Sequence[Windows]) -> SegmentSet:
    """Pad the training segments of some logs once, for all loss evaluations.

    Parameters
    ----------
    logs : sequence of WheelLog
        The training logs.
    windows : sequence of Windows
        Their segments (e.g. from :func:`training_windows`), one per log.

    Returns
    -------
    SegmentSet
    """
    blocks: list[_Block] = []
    for full_log, full_win in zip(logs, windows, strict=True):
        log, win = _merge_constant_steps(full_log, full_win)
        n_steps = win.end - win.start
        if n_steps.size == 0:
            continue
        bucket = np.ceil(np.log2(n_steps)).astype(int)
        for b in np.unique(bucket):
            idx = np.flatnonzero(bucket == b)
            per_block = max(1, _BUCKET_ELEMENTS >> int(b))
            for i in range(0, idx.size, per_block):
                part = idx[i : i + per_block]
                rows, valid, dt = padded_steps(log, win, part)
                blocks.append(
                    _Block(
                        v_l=np.where(valid, log.v_l[rows], 0.0),
                        v_r=np.where(valid, log.v_r[rows], 0.0),
                        dt=dt,
                        target=relative_pose(log.pose[win.start[part]], log.pose[win.end[part]]),
                    )
                )
    count = sum(b.target.shape[0] for b in blocks)
    length = float(sum(w.length.sum() for w in windows))
    duration = float(sum(b.dt.sum() for b in blocks))
    return SegmentSet(tuple(blocks), count, length, duration)


def _merge_constant_steps(log: WheelLog, windows: Windows) -> tuple[WheelLog, Windows]:
    """Merge consecutive steps with equal track speeds inside each window.

    Every model's twist depends on the current speeds only, and a constant
    twist integrates exactly over the merged duration, so the predicted end
    poses are unchanged; the logs hold each wheel reading for ~5 rows, so this
    divides the integration work accordingly. Keeps the window start and end
    rows and every row where the speeds change inside a window.
    """
    n = len(log)
    inside = np.zeros(n + 1, dtype=int)
    np.add.at(inside, windows.start, 1)
    np.add.at(inside, windows.end, -1)
    in_window = np.cumsum(inside)[:n] > 0
    changed = np.r_[True, (log.v_l[1:] != log.v_l[:-1]) | (log.v_r[1:] != log.v_r[:-1])]
    keep = in_window & changed
    keep[windows.start] = True
    keep[windows.end] = True
    rows = np.flatnonzero(keep)
    merged = WheelLog(
        log.t[rows], log.v_l[rows], log.v_r[rows], log.pose[rows], None, log.segment[rows],
        log.source,
    )  # fmt: skip
    where = np.searchsorted(rows, [windows.start, windows.end])
    return merged, Windows(start=where[0], end=where[1], length=windows.length)
