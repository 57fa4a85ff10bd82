"""Merge the streams read from a bag (wheels, poses, headings) into one wheel log.

Pure array work, no files. Stamps are integer nanoseconds; rows are keyed
by the microsecond (the wheel log's resolution), so a pose stamped within
half a microsecond of a wheel sample lands on that sample's row. The rules
(docs/bags.md):

- wheel samples are sorted by stamp (a stable sort; how many arrived out of
  order is counted), and of several with the same stamp the last in the bag
  is kept;
- a gap between wheel samples longer than ``max_gap`` starts a new segment;
- a pose or heading gets a row of its own at its stamp, carrying the wheel
  speeds of the sample before it (the log's zero-order hold, so the speed
  signal is unchanged), in that sample's segment; one before the first
  wheel sample, after the last, or inside a gap is dropped and counted;
- a heading on the row of a pose that has a yaw is dropped and counted (the
  pose's yaw is kept); a position without yaw (GPS) and a heading at the
  same stamp share the row.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from terrain_odom.records import WheelLog

__all__ = ["MergedLog", "StampedRows", "merge_streams", "time_origin_ns"]

_NS_PER_US = 1000


@dataclass(frozen=True)
class StampedRows:
    """Samples of one stream: stamps (int64 ns) and values, shape (N,) or (N, K)."""

    stamp_ns: np.ndarray
    values: np.ndarray

    def __len__(self) -> int:
        return int(self.stamp_ns.shape[0])


@dataclass(frozen=True)
class MergedLog:
    """The merged log and what merging did: rows dropped (by reason) and re-ordered."""

    log: WheelLog
    origin_ns: int
    dropped: dict[str, int] = field(default_factory=dict)
    out_of_order: int = 0


def time_origin_ns(stamp_ns: np.ndarray) -> int:
    """Return the log's time origin: the first stamp rounded down to a whole second, ns.

    Examples
    --------
    >>> time_origin_ns(np.array([5_700_000_000, 5_200_000_000]))
    5000000000
    """
    return int(stamp_ns.min()) // 1_000_000_000 * 1_000_000_000


def _keys(stamp_ns: np.ndarray) -> np.ndarray:
    """Microsecond keys of nanosecond stamps (rounded to nearest)."""
    return (np.asarray(stamp_ns, dtype=np.int64) + _NS_PER_US // 2) // _NS_PER_US


def _last_per_key(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sorted unique keys and, for each, the index of its last occurrence (stable)."""
    order = np.argsort(keys, kind="stable")
    sorted_keys = keys[order]
    last = np.r_[sorted_keys[1:] != sorted_keys[:-1], True]
    return sorted_keys[last], order[last]


def _out_of_order(stamp_ns: np.ndarray) -> int:
    """How many samples have a stamp before the one read before them."""
    return int(np.count_nonzero(np.diff(stamp_ns) < 0)) if stamp_ns.size > 1 else 0


def merge_streams(
    wheels: StampedRows,
    poses: StampedRows | None,
    headings: StampedRows | None,
    *,
    max_gap: float,
    source: str = "<bag>",
) -> MergedLog:
    """Merge wheel speeds, poses and headings into a :class:`WheelLog` (module docstring).

    Parameters
    ----------
    wheels : StampedRows
        Track speeds, values of shape (N, 2): ``v_l, v_r`` (m/s); N >= 1.
    poses : StampedRows, optional
        Poses, values (M, 3): ``x, y, yaw`` (yaw NaN for a position alone).
    headings : StampedRows, optional
        Headings, values (H,): ``yaw`` (rad).
    max_gap : float
        Longest gap between wheel samples within a segment, s.
    source : str
        The log's ``source`` (the bag), for messages.

    Returns
    -------
    MergedLog
        ``dropped`` counts by reason (``duplicate wheel stamp``, ``pose
        outside the wheel samples``, ...); ``out_of_order`` counts wheel
        samples that came before their predecessor's stamp.

    Examples
    --------
    >>> wheels = StampedRows(np.array([0, 100_000_000, 200_000_000]) + 10**9,
    ...                      np.array([[1.0, 1.0], [2.0, 2.0], [3.0, 3.0]]))
    >>> poses = StampedRows(np.array([1_150_000_000]), np.array([[1.0, 2.0, 0.5]]))
    >>> merged = merge_streams(wheels, poses, None, max_gap=1.0)
    >>> merged.log.t.tolist(), merged.log.v_l.tolist()
    ([0.0, 0.1, 0.15, 0.2], [1.0, 2.0, 2.0, 3.0])
    """
    w_keys, w_idx = _last_per_key(_keys(wheels.stamp_ns))
    dropped = {"duplicate wheel stamp": len(wheels) - int(w_keys.size)}
    speeds = np.asarray(wheels.values, dtype=float)[w_idx]
    max_gap_us = int(round(max_gap * 1e6))
    segment = np.r_[0, np.cumsum(np.diff(w_keys) > max_gap_us)].astype(np.int64)
    events = _events(w_keys, poses, "pose", max_gap_us, dropped)
    heading_events = _events(w_keys, headings, "heading", max_gap_us, dropped)
    keys = np.unique(np.concatenate([w_keys, events[0], heading_events[0]]))
    pose = np.full((keys.size, 3), np.nan)
    pose[np.searchsorted(keys, events[0])] = events[1]
    rows = np.searchsorted(keys, heading_events[0])
    taken = ~np.isnan(pose[rows, 2])
    dropped["heading on the row of a pose with yaw"] = int(np.count_nonzero(taken))
    pose[rows[~taken], 2] = heading_events[1][~taken]
    prev = np.searchsorted(w_keys, keys, side="right") - 1
    origin_us = time_origin_ns(w_keys * _NS_PER_US) // _NS_PER_US
    log = WheelLog(
        t=(keys - origin_us) / 1e6,
        v_l=speeds[prev, 0],
        v_r=speeds[prev, 1],
        pose=pose,
        terrain=None,
        segment=segment[prev],
        source=source,
    )
    dropped = {reason: n for reason, n in dropped.items() if n}
    return MergedLog(log, origin_us * _NS_PER_US, dropped, _out_of_order(wheels.stamp_ns))


def _events(
    w_keys: np.ndarray,
    rows: StampedRows | None,
    name: str,
    max_gap_us: int,
    dropped: dict[str, int],
) -> tuple[np.ndarray, np.ndarray]:
    """Keys and values of the pose (or heading) samples that fall inside the wheel samples."""
    if rows is None or len(rows) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 3) if name == "pose" else 0)
    keys, idx = _last_per_key(_keys(rows.stamp_ns))
    dropped[f"duplicate {name} stamp"] = len(rows) - int(keys.size)
    values = np.asarray(rows.values, dtype=float)[idx]
    prev = np.searchsorted(w_keys, keys, side="right") - 1
    outside = (prev < 0) | (keys > w_keys[-1])
    in_gap = ~outside & (keys - w_keys[np.maximum(prev, 0)] > max_gap_us)
    dropped[f"{name} outside the wheel samples"] = int(np.count_nonzero(outside))
    dropped[f"{name} in a gap of the wheel samples"] = int(np.count_nonzero(in_gap))
    keep = ~outside & ~in_gap
    return keys[keep], values[keep]
