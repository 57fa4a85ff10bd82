"""The plots of a run: trajectory and position error, states over time, frame labels.

Each function returns a matplotlib ``Figure`` (Agg canvas, no display);
:func:`~terrain_odom.reporting.figure.save_png` writes it. Lines are drawn
with at most :data:`~terrain_odom.reporting.figure.MAX_POINTS` points
(:func:`~terrain_odom.reporting.figure.decimate`); nothing is scored here.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from terrain_odom.estimation.odometry import OdometryResult
from terrain_odom.records import GroundTruth, TerrainChange, WheelLog
from terrain_odom.reporting.figure import (
    UNKNOWN,
    colour_of,
    decimate,
    new_figure,
    terrain_colours,
    terrain_spans,
    wrap,
)

__all__ = [
    "STATE_UNITS",
    "trajectory_figure",
    "states_figure",
    "data_breaks",
    "frame_labels_figure",
    "travelled",
]

STATE_UNITS = {"y_l": "m", "y_r": "m", "x_icr": "m", "alpha": "-"}
"""The states drawn against time, and their units."""

_VARIANT_STYLES: tuple[tuple[str, Any], ...] = (
    ("tab:blue", (0, (1, 1.2))),
    ("black", "--"),
    ("tab:purple", "-."),
    ("tab:brown", (0, (5, 1, 1, 1, 1, 1))),
)
"""Colour and line style of each filter variant (the run itself: solid, by terrain)."""


def travelled(xy: np.ndarray, breaks: np.ndarray | None = None) -> np.ndarray:
    """Return the distance travelled along a path at each of its points, m.

    Parameters
    ----------
    xy : ndarray, shape (N, 2)
    breaks : ndarray of int, optional
        Rows where a new piece starts (no distance from the row before).

    Examples
    --------
    >>> travelled(np.array([[0.0, 0.0], [3.0, 4.0], [3.0, 5.0]])).tolist()
    [0.0, 5.0, 6.0]
    """
    steps = np.hypot(*np.diff(xy, axis=0).T) if len(xy) > 1 else np.zeros(0)
    steps = np.nan_to_num(steps)
    if breaks is not None:
        steps[np.asarray(breaks, dtype=int)[np.asarray(breaks) > 0] - 1] = 0.0
    return np.concatenate(([0.0], np.cumsum(steps)))


def data_breaks(log: WheelLog) -> np.ndarray:
    """Rows where the data break: every segment start and every change of the log's terrain label.

    Lines are not drawn across them: a new segment (its time restarts, or a
    stitched recording) starts elsewhere, and a stitched log changes terrain
    where one recording ends and the next begins.

    Examples
    --------
    >>> log = WheelLog(np.arange(4.0), np.zeros(4), np.zeros(4), np.full((4, 3), np.nan),
    ...                np.array(["grass", "grass", "asphalt", "asphalt"]), np.zeros(4, int))
    >>> data_breaks(log).tolist()
    [0, 2]
    """
    starts = log.run_starts()
    if log.terrain is None or len(log) < 2:
        return starts
    changes = np.flatnonzero(log.terrain[1:] != log.terrain[:-1]) + 1
    return np.union1d(starts, changes)


def _broken(values: np.ndarray, index: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """``values[index]`` as float, with a NaN row before every piece start (lines break there)."""
    picked = np.asarray(values, dtype=float)[index]
    cut = np.searchsorted(index, starts[starts > 0])
    return np.insert(picked, cut, np.nan, axis=0)


def _path_segments(xy: np.ndarray, labels: np.ndarray, starts: np.ndarray) -> tuple[Any, Any]:
    """Line segments of a path and their labels, none across a piece start."""
    segments = np.stack([xy[:-1], xy[1:]], axis=1)
    keep = np.ones(len(segments), dtype=bool)
    keep[starts[(starts > 0) & (starts <= len(segments))] - 1] = False
    return segments[keep], labels[:-1][keep]


def _draw_estimate(ax: Any, result: OdometryResult, starts: np.ndarray) -> dict[str, str]:
    """Draw the estimated path coloured by the confirmed terrain; return the terrain colours."""
    from matplotlib.collections import LineCollection

    index = decimate(len(result.states))
    xy = result.states[index, :2]
    labels = np.asarray(result.terrain).astype(str)[index]
    colours = terrain_colours(np.unique(labels))
    piece = np.searchsorted(index, starts)
    segments, seg_labels = _path_segments(xy, labels, piece)
    ax.add_collection(
        LineCollection(segments, colors=[colour_of(colours, s) for s in seg_labels], lw=2.6)
    )
    if colours:
        for name, colour in colours.items():
            ax.plot([], [], color=colour, lw=2.0, label=f"estimate on {wrap(name, 20)}")
    else:
        ax.plot([], [], color=colour_of(colours, ""), lw=2.0, label="estimate")
    ax.plot(*xy[0], "o", ms=8, mfc="white", mec="black", mew=1.5, label="start", zorder=5)
    ax.plot(*xy[-1], "s", ms=7, color="black", label="end", zorder=5)
    return colours


def _aspect(*paths: np.ndarray) -> float:
    """Return the height-to-width ratio of the paths' extent, clipped to [0.35, 1.3]."""
    xy = np.concatenate(paths)
    xy = xy[np.isfinite(xy).all(axis=1)]
    if len(xy) == 0:
        return 1.0
    dx, dy = np.ptp(xy, axis=0) + 1e-9
    return float(np.clip(dy / dx, 0.35, 1.3))


def _position_error(xy: np.ndarray, reference: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows where ``reference`` has a position, and the distance of ``xy`` from it there, m."""
    rows = np.flatnonzero(np.isfinite(reference).all(axis=1))
    return rows, np.hypot(*(xy[rows] - reference[rows]).T)


def _truth_at(truth: GroundTruth, t: np.ndarray) -> np.ndarray:
    """Return the true positions at the times ``t`` (linear interpolation), m."""
    return np.column_stack([np.interp(t, truth.t, truth.pose[:, i]) for i in range(2)])


def trajectory_figure(
    log: WheelLog,
    result: OdometryResult,
    *,
    truth: GroundTruth | None = None,
    variants: Mapping[str, OdometryResult] | None = None,
) -> Any:
    """Trajectory (x, y in m, equal axes) and, with poses or truth, position error against distance.

    Parameters
    ----------
    log : WheelLog
        The run's log: its measured poses are drawn as dots.
    result : OdometryResult
        The run: its path coloured by the confirmed terrain, start and end marked.
    truth : GroundTruth, optional
        Drawn as a thick grey line; the error panel then shows each path's
        distance from it.
    variants : mapping of str to OdometryResult, optional
        Other filter runs on the same log, drawn in black line styles.

    Returns
    -------
    matplotlib.figure.Figure
        Axes ``trajectory`` and, when the log has positions or ``truth`` is
        given, ``position error``.
    """
    measured = log.pose[:, :2]
    has_error = truth is not None or bool(np.isfinite(measured).all(axis=1).any())
    ratio = _aspect(result.states[:, :2], measured)
    height = 5.6 * ratio + (2.6 if has_error else 0.6)
    fig = new_figure(9.0, height)
    ratios = [5.6 * ratio, 2.0] if has_error else None
    axes = fig.subplots(2 if has_error else 1, 1, height_ratios=ratios)
    ax = axes[0] if has_error else axes
    starts = data_breaks(log)
    if truth is not None:
        inside = (truth.t >= log.t[0]) & (truth.t <= log.t[-1])
        t_xy = truth.pose[inside, :2][decimate(int(inside.sum()))]
        ax.plot(*t_xy.T, "-", color="0.55", lw=5, alpha=0.5, label="ground truth", zorder=1)
    index = decimate(len(log))
    posed = np.flatnonzero(np.isfinite(measured).all(axis=1))
    if posed.size:
        dots = measured[posed[decimate(posed.size)]]
        ax.plot(*dots.T, ".", color="black", ms=2.0, label="measured poses", zorder=3)
    _draw_estimate(ax, result, starts)
    for (colour, style), (name, other) in zip(
        _VARIANT_STYLES, (variants or {}).items(), strict=False
    ):
        xy = _broken(other.states[:, :2], index, starts)
        ax.plot(*xy.T, color=colour, ls=style, lw=1.0, label=wrap(name, 24), zorder=4)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.autoscale_view()
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    ax.set_title("trajectory")
    if has_error:
        _draw_errors(axes[1], log, result, truth, variants or {})
    return fig


def _draw_errors(
    ax: Any,
    log: WheelLog,
    result: OdometryResult,
    truth: GroundTruth | None,
    variants: Mapping[str, OdometryResult],
) -> None:
    """Position error of the estimate (and variants) against distance travelled."""
    xy = result.states[:, :2]
    distance = travelled(xy, log.run_starts())
    if truth is not None:
        reference, what = _truth_at(truth, log.t), "ground truth"
    else:
        reference, what = log.pose[:, :2], "measured pose"
    paths: dict[str, tuple[np.ndarray, str, Any]] = {"estimate": (xy, "C3", "-")}
    for (colour, style), (name, other) in zip(_VARIANT_STYLES, variants.items(), strict=False):
        paths[name] = (other.states[:, :2], colour, style)
    marker = "" if truth is not None else "."
    for name, (path, colour, style) in paths.items():
        rows, error = _position_error(path, reference)
        keep = rows[decimate(rows.size)]
        ax.plot(distance[keep], error[np.searchsorted(rows, keep)], color=colour, ls=style,
                lw=0.9, marker=marker, ms=3, label=wrap(name, 24))  # fmt: skip
    ax.set_xlabel("distance travelled along the estimate (m)")
    ax.set_ylabel("position error (m)")
    ax.set_ylim(bottom=0.0)
    ax.ticklabel_format(axis="y", useOffset=False)
    fused = "" if truth is not None else " (poses fused by the filter)"
    ax.set_title(f"position error: distance from the {what}{fused}")
    ax.grid(True, alpha=0.3)
    if len(paths) > 1:
        ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)


def _shade_terrain(ax: Any, spans: Sequence[tuple[float, float, str]], colours: dict) -> None:
    for start, end, label in spans:
        if label:
            ax.axvspan(start, end, color=colour_of(colours, label), alpha=0.15, lw=0)


def _mark_changes(ax: Any, changes: Sequence[TerrainChange]) -> None:
    for change in changes:
        if change.restored:
            ax.axvline(change.t, color="tab:blue", ls="--", lw=1.0)
        elif change.reset:
            ax.axvline(change.t, color="tab:red", ls="-", lw=1.0)


def _change_legend(ax: Any, changes: Sequence[TerrainChange], colours: dict[str, str]) -> None:
    """Put a legend under the axes: terrains, resets, memory restores, truth."""
    handles, labels = ax.get_legend_handles_labels()
    from matplotlib.patches import Patch

    for name, colour in colours.items():
        handles.append(Patch(color=colour, alpha=0.3))
        labels.append(wrap(name, 20))
    if any(c.reset and not c.restored for c in changes):
        handles.append(ax.plot([], [], color="tab:red", lw=1.0)[0])
        labels.append("covariance reset")
    if any(c.restored for c in changes):
        handles.append(ax.plot([], [], color="tab:blue", ls="--", lw=1.0)[0])
        labels.append("terrain memory restored")
    if handles:
        ncol = min(len(handles), 4)
        ax.legend(handles, labels, fontsize=8, ncol=ncol, loc="upper center",
                  bbox_to_anchor=(0.5, -0.35), frameon=False)  # fmt: skip


def states_figure(
    t: np.ndarray,
    result: OdometryResult,
    *,
    truth: GroundTruth | None = None,
    starts: np.ndarray | None = None,
) -> Any:
    """ICR states (and ``alpha``) against time with +-2 sigma bands; terrain and resets marked.

    Parameters
    ----------
    t : ndarray, shape (N,)
        Row times, s.
    result : OdometryResult
        The run: states, standard deviations, confirmed terrain per row
        (shaded spans) and changes (vertical lines: red a covariance reset,
        dashed blue a terrain-memory restore).
    truth : GroundTruth, optional
        True ICRs (and ``alpha``), drawn in black.
    starts : ndarray of int, optional
        Rows where a segment starts (its time may restart): lines break there.

    Returns
    -------
    matplotlib.figure.Figure
        One axis per state of :data:`STATE_UNITS` the run has.
    """
    names = [n for n in STATE_UNITS if n in result.names]
    fig = new_figure(8.0, 1.2 + 1.9 * len(names))
    axes = fig.subplots(len(names), 1, sharex=True, squeeze=False)[:, 0]
    index = decimate(len(t))
    labels = np.asarray(result.terrain).astype(str)
    colours = terrain_colours(np.unique(labels))
    spans = terrain_spans(t, labels)  # every row: no span is lost to the decimation
    truth_values = _truth_states(truth, t) if truth is not None else {}
    cuts = np.zeros(0, dtype=int) if starts is None else np.asarray(starts, dtype=int)
    t_line = _broken(t, index, cuts)  # NaN between segments: no line joins them
    for ax, name in zip(axes, names, strict=True):
        col = list(result.names).index(name)
        value = _broken(result.states[:, col], index, cuts)
        std = _broken(result.stds[:, col], index, cuts)
        _shade_terrain(ax, spans, colours)
        ax.fill_between(t_line, value - 2 * std, value + 2 * std, color="C0", alpha=0.25,
                        lw=0, label="estimate ± 2σ")  # fmt: skip
        ax.plot(t_line, value, color="C0", lw=1.2, label="estimate")
        if name in truth_values:
            truth_line = _broken(truth_values[name], index, cuts)
            ax.plot(t_line, truth_line, "k--", lw=1.0, label="truth")
        _mark_changes(ax, result.changes)
        ax.set_ylabel(f"{name} ({STATE_UNITS[name]})")
        ax.grid(True, alpha=0.3)
    axes[0].set_title("ICR states (shaded: confirmed terrain)")
    axes[-1].set_xlabel("t (s)")
    axes[-1].set_xlim(float(np.min(t)), float(np.max(t)))  # segments may restart time
    _change_legend(axes[-1], result.changes, colours)
    return fig


def _truth_states(truth: GroundTruth, t: np.ndarray) -> dict[str, np.ndarray]:
    """Return the true ``y_l, y_r, x_icr`` (and ``alpha``) at the times ``t``."""
    values = {
        n: np.interp(t, truth.t, truth.icr[:, i]) for i, n in enumerate(("y_l", "y_r", "x_icr"))
    }
    if truth.alpha is not None:
        values["alpha"] = np.interp(t, truth.t, truth.alpha)
    return values


def frame_labels_figure(t: np.ndarray, labels: Sequence[str], truth: Sequence[str]) -> Any:
    """Frame labels over time against the true terrain of the ground each frame classified.

    Parameters
    ----------
    t : ndarray, shape (F,)
        Frame times, s.
    labels : sequence of str
        Each frame's label (``""``: not classified, not drawn).
    truth : sequence of str
        Each frame's true terrain; ``""`` or ``"unknown"``: not known, and
        such a label is drawn as unknown (grey), never as wrong.

    Returns
    -------
    matplotlib.figure.Figure
        One axis, ``frame labels``.
    """
    known = np.array([bool(c) and c != UNKNOWN for c in truth])
    classes = sorted({str(c) for c in (*labels, *truth) if c and c != UNKNOWN})
    row = {c: i for i, c in enumerate(classes)}
    fig = new_figure(8.0, 1.8 + 0.35 * len(classes))
    ax = fig.subplots()
    truth_y = np.array([row.get(str(c), np.nan) for c in truth], dtype=float)
    label_y = np.array([row.get(str(c), np.nan) for c in labels], dtype=float)
    right = known & (label_y == truth_y)
    wrong = known & (label_y != truth_y) & np.isfinite(label_y)
    unknown = ~known & np.isfinite(label_y)
    ax.plot(t, truth_y, "k-", lw=6, alpha=0.25, label="true terrain")
    ax.plot(t[right], label_y[right], "g.", ms=5, label="label (right)")
    ax.plot(t[wrong], label_y[wrong], "rx", ms=6, label="label (wrong)")
    ax.plot(t[unknown], label_y[unknown], "o", mfc="none", mec="0.5", ms=4,
            label="label (truth unknown)")  # fmt: skip
    ax.set_yticks(range(len(classes)), [wrap(c, 16) for c in classes])
    ax.set_ylim(-0.5, len(classes) - 0.5)
    ax.set_xlabel("t (s)")
    ax.set_ylabel("terrain")
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.25 - 0.1 / max(1, len(classes))),
              ncol=4, frameon=False)  # fmt: skip
    ax.set_title("frame labels against the true terrain of the classified ground")
    return fig
