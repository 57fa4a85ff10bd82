"""Shared drawing helpers: an Agg figure, its PNG, terrain colours, decimation, long labels.

Every plot of :mod:`terrain_odom.reporting` is built by a function that
returns a matplotlib ``Figure`` (so tests inspect its axes) and written by
:func:`save_png` into a binary handle (so callers write files atomically).
matplotlib is imported inside the functions: importing this module stays cheap.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any, BinaryIO

import numpy as np

__all__ = [
    "DPI",
    "MAX_POINTS",
    "UNKNOWN",
    "new_figure",
    "save_png",
    "decimate",
    "terrain_colours",
    "colour_of",
    "terrain_spans",
    "wrap",
]

DPI = 110
"""Resolution of the PNGs, dots per inch."""

MAX_POINTS = 4000
"""Most points a line is drawn with (:func:`decimate`); scores use every row."""

UNKNOWN = "unknown"
"""Label of frames or rows whose true terrain is not known."""

_PALETTE = (
    "#1b9e77",
    "#d95f02",
    "#7570b3",
    "#e7298a",
    "#66a61e",
    "#e6ab02",
    "#a6761d",
    "#1f78b4",
    "#b2df8a",
    "#fb9a99",
    "#cab2d6",
    "#fdbf6f",
)


def new_figure(width: float, height: float) -> Any:
    """Return a matplotlib ``Figure`` on the Agg canvas (no display, no pyplot state).

    Parameters
    ----------
    width, height : float
        Size, inches (the PNG is ``DPI`` times that in pixels).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def save_png(fig: Any, handle: BinaryIO, dpi: int = DPI) -> None:
    """Write ``fig`` (from :func:`new_figure`) as a PNG into the binary ``handle``.

    The same bytes as ``fig.savefig(handle, format="png", dpi=dpi)``, in one
    layout and one draw: ``savefig`` lays the figure out in a draw of its own
    (nothing rendered) before the real one, ~30 ms more a run's figure.
    """
    fig.set_dpi(dpi)
    fig.canvas.print_png(handle)


def decimate(n: int, max_points: int = MAX_POINTS) -> np.ndarray:
    """Return at most about ``max_points`` evenly spaced indices of ``n`` rows, first and last kept.

    Examples
    --------
    >>> decimate(5, 10).tolist()
    [0, 1, 2, 3, 4]
    >>> decimate(10, 4).tolist()
    [0, 3, 6, 9]
    >>> decimate(0).size
    0
    """
    if n <= max_points:
        return np.arange(n)
    step = int(np.ceil((n - 1) / (max_points - 1)))
    index = np.arange(0, n, step)
    return index if index[-1] == n - 1 else np.append(index, n - 1)


def terrain_colours(labels: Iterable[Any]) -> dict[str, str]:
    """Return a colour per terrain label, in sorted order (grey for ``""`` and unknown).

    Labels beyond the twelve colours of the palette cycle through it again.

    Examples
    --------
    >>> terrain_colours(["gravel", "grass", "grass"])
    {'grass': '#1b9e77', 'gravel': '#d95f02'}
    """
    names = sorted({str(label) for label in labels} - {"", UNKNOWN})
    colours = {name: _PALETTE[i % len(_PALETTE)] for i, name in enumerate(names)}
    return colours


def colour_of(colours: dict[str, str], label: Any) -> str:
    """Return the colour of ``label`` in ``colours``, grey if it has none."""
    return colours.get(str(label), "#9a9a9a")


def terrain_spans(
    t: np.ndarray, labels: Sequence[Any] | np.ndarray
) -> list[tuple[float, float, str]]:
    """Return ``(start, end, label)`` of each run of equal labels over the times ``t``.

    Examples
    --------
    >>> terrain_spans(np.arange(5.0), ["a", "a", "b", "b", "b"])
    [(0.0, 2.0, 'a'), (2.0, 4.0, 'b')]
    """
    values = np.asarray(labels).astype(str)
    if values.size == 0:
        return []
    starts = np.concatenate(([0], np.flatnonzero(values[1:] != values[:-1]) + 1))
    ends = np.append(starts[1:], values.size - 1)
    return [(float(t[a]), float(t[b]), str(values[a])) for a, b in zip(starts, ends, strict=True)]


def wrap(label: str, width: int = 14) -> str:
    """Return ``label`` broken into lines of at most about ``width`` characters.

    Lines break after a space, ``_`` or ``-`` where one is near enough, else
    at ``width``.

    >>> print(wrap("gravel_wet_2024_7_29", 10))
    gravel_wet
    _2024_7_29
    >>> wrap("grass", 10)
    'grass'
    """
    lines = []
    rest = label
    while len(rest) > width:
        cut = max(rest.rfind(c, width // 2, width + 1) for c in " _-")
        cut = width if cut <= 0 else cut
        lines.append(rest[:cut].rstrip())
        rest = rest[cut:].lstrip(" ")
    return "\n".join([*lines, rest])
