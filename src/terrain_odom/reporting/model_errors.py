"""Plots of model-odometry errors: per window against distance, and box plots per terrain.

Baril et al. (CRV 2020) show the error per metre of each model over ``h_e``
windows as box plots per terrain (their Fig. 5-6); :func:`error_boxes_figure`
draws that, :func:`window_errors_figure` the same errors window by window
along the log, so that where a model goes wrong can be read off the path.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from terrain_odom.evaluation.metrics import WindowErrors
from terrain_odom.reporting.figure import (
    colour_of,
    decimate,
    new_figure,
    terrain_colours,
    wrap,
)

__all__ = ["ErrorValues", "error_values", "window_errors_figure", "error_boxes_figure"]

ErrorValues = tuple[np.ndarray, np.ndarray]
"""Translational (m/m) and angular (deg/m) errors per metre of a set of windows."""

_MEASURES = (("translational error (m/m)", 0), ("angular error (deg/m)", 1))
_UNITS = ("m/m", "deg/m")


def error_values(errors: WindowErrors | Sequence[WindowErrors]) -> ErrorValues:
    """Return the per-metre errors of windows (of several logs, concatenated).

    Examples
    --------
    >>> from terrain_odom.evaluation.windows import Windows
    >>> w = Windows(np.array([0]), np.array([4]), np.array([2.0]))
    >>> e = WindowErrors(w, np.zeros((1, 3)), np.array([0.5]), np.array([np.pi / 90]))
    >>> [v.tolist() for v in error_values([e, e])]
    [[0.25, 0.25], [1.0, 1.0]]
    """
    items = [errors] if isinstance(errors, WindowErrors) else list(errors)
    if not items:
        return np.zeros(0), np.zeros(0)
    return (
        np.concatenate([e.translation_per_m for e in items]),
        np.concatenate([e.rotation_per_m for e in items]),
    )


def _positive(values: np.ndarray) -> np.ndarray:
    """Values for a log axis: zeros lifted to the smallest positive value (or 1e-6)."""
    positive = values[values > 0]
    floor = positive.min() if positive.size else 1e-6
    return np.maximum(values, floor)


def _log_scale(ax: Any, measured: bool) -> None:
    """Put an axis on a log scale, or say in it that nothing was measured (a GPS without heading)."""
    if measured:
        ax.set_yscale("log")
    else:
        ax.text(0.5, 0.5, "not measured", transform=ax.transAxes, ha="center", va="center")


def window_errors_figure(
    errors: Mapping[str, WindowErrors],
    distance: np.ndarray,
    terrain: Sequence[str] | np.ndarray | None,
    horizon: float,
) -> Any:
    """Error per metre of every window against the distance travelled, one row per model.

    Parameters
    ----------
    errors : mapping of str to WindowErrors
        Per model, its errors on the windows of one log.
    distance : ndarray, shape (N,)
        Distance travelled at each log row, m (the window's start row is used).
    terrain : sequence of str, shape (N,), optional
        Terrain of each log row: the points' colour.
    horizon : float
        ``h_e``, m (in the title).

    Returns
    -------
    matplotlib.figure.Figure
        A ``len(errors) x 2`` grid of axes (m/m, deg/m); each shows the
        model's median as a black line, named in its legend.
    """
    names = list(errors)
    fig = new_figure(10.0, 1.0 + 2.0 * len(names))
    grid = fig.subplots(len(names), 2, sharex=True, sharey="col", squeeze=False)
    labels = np.asarray(terrain if terrain is not None else [""] * len(distance)).astype(str)
    colours = terrain_colours(labels)
    for row, name in zip(grid, names, strict=True):
        e = errors[name]
        start = e.windows.start
        pick = decimate(len(start))
        values = error_values(e)
        for ax, (unit, k) in zip(row, _MEASURES, strict=True):
            v = values[k]
            ax.scatter(distance[start][pick], _positive(v)[pick], s=4, lw=0,
                       c=[colour_of(colours, s) for s in labels[start][pick]])  # fmt: skip
            measured = v[~np.isnan(v)]  # NaN: not measured (a heading on position windows)
            median = float(np.median(measured)) if measured.size else float("nan")
            ax.axhline(median, color="black", lw=1.2)
            shown = f"median {median:.3g} {_UNITS[k]}" if measured.size else "not measured"
            ax.set_title(shown, fontsize=8, loc="right")
            _log_scale(ax, measured.size > 0)
            ax.grid(True, alpha=0.3)
            ax.set_ylabel(unit, fontsize=8)
        row[0].set_title(wrap(name, 50), fontsize=9, loc="left")
    for ax in grid[-1]:
        ax.set_xlabel("distance travelled at the window start (m)")
    fig.suptitle(f"Model error per metre over h_e = {horizon:g} m windows")
    _terrain_legend(fig, colours)
    return fig


def _terrain_legend(fig: Any, colours: dict[str, str]) -> None:
    """Put the terrain colours in a legend under the figure."""
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], ls="", marker="o", color=c) for c in colours.values()]
    labels = [f"window starting on {wrap(n, 20)}" for n in colours]
    handles.append(Line2D([], [], color="black", lw=1.2))
    labels.append("median of the model")
    fig.legend(handles, labels, loc="outside lower center", ncol=min(4, len(handles)),
               fontsize=8, frameon=False)  # fmt: skip


def _model_ticks(ax: Any, names: Sequence[str], width: float, size: float = 9.0) -> None:
    """Name the models under ``ax``: wrapped to the room each has, or turned upright if too narrow."""
    room = 0.8 * width * 72.0 / max(1, len(names))  # points per model
    chars = int(room / (0.62 * size))
    if chars >= 10:
        ax.set_xticks(np.arange(len(names)), [wrap(n, chars) for n in names], fontsize=size)
    else:
        ax.set_xticks(np.arange(len(names)), [wrap(n, 40) for n in names], fontsize=size,
                      rotation=90)  # fmt: skip


def error_boxes_figure(
    values: Mapping[str, Mapping[str, ErrorValues]], horizon: float, title: str = "Model error"
) -> Any:
    """Box plots of the per-metre errors per model and terrain (Baril et al. Fig. 5-6 style).

    Parameters
    ----------
    values : mapping of str to mapping of str to ErrorValues
        Per model (in order), per terrain: the errors (:func:`error_values`).
    horizon : float
        ``h_e``, m (in the title).
    title : str
        Start of the title, e.g. ``"Held-out model error"``.

    Returns
    -------
    matplotlib.figure.Figure
        Two axes (m/m, deg/m), log scale; boxes without outliers, one colour
        per terrain; model names wrapped or rotated so none overlap.
    """
    names = list(values)
    groups = sorted({g for per_terrain in values.values() for g in per_terrain})
    colours = terrain_colours(groups)
    width = 0.8 / max(1, len(groups))
    fig = new_figure(min(16.0, max(6.5, 2.0 + 0.45 * len(names) * len(groups))), 7.5)
    axes = fig.subplots(2, 1, sharex=True)
    for ax, (unit, k) in zip(axes, _MEASURES, strict=True):
        for j, g in enumerate(groups):
            data = [values[n].get(g, (np.zeros(0), np.zeros(0)))[k] for n in names]
            data = [d[~np.isnan(d)] for d in data]  # NaN: not measured
            pos = np.arange(len(names)) + (j - (len(groups) - 1) / 2) * width
            keep = [i for i, d in enumerate(data) if d.size]
            if not keep:
                continue
            box = ax.boxplot([_positive(data[i]) for i in keep], positions=pos[keep],
                             widths=0.9 * width, showfliers=False, patch_artist=True,
                             medianprops={"color": "black"})  # fmt: skip
            for patch in box["boxes"]:
                patch.set_facecolor(colour_of(colours, g))
                patch.set_alpha(0.7)
            for line in box["medians"]:
                line.set_gid("median")
            ax.plot([], [], color=colour_of(colours, g), lw=6, alpha=0.7, label=wrap(g, 20))
        ax.set_ylabel(unit)
        _log_scale(ax, any(v[k][~np.isnan(v[k])].size for m in values.values() for v in m.values()))
        ax.grid(True, axis="y", alpha=0.3)
    _model_ticks(axes[1], names, fig.get_figwidth())
    drawn = next((ax for ax in axes if ax.get_legend_handles_labels()[0]), None)
    if drawn is not None:  # the axis something was measured on (headings alone: the lower one)
        drawn.legend(title="terrain", fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    axes[0].set_title(f"{title} over h_e = {horizon:g} m windows")
    return fig
