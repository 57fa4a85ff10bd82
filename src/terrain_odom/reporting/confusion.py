"""Confusion matrices side by side, sized and lettered for 2 to a dozen or more classes."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from terrain_odom.reporting.figure import new_figure, wrap

__all__ = ["ConfusionPanel", "confusion_layout", "confusion_figure"]

ConfusionPanel = tuple[str, np.ndarray]
"""A title and a row-normalised confusion matrix, % (row: true class, column: predicted)."""


def confusion_layout(n: int) -> tuple[float, float, str]:
    """Return the cell size (in), the cell font size (pt) and the number format for ``n`` classes.

    Cells shrink from 0.8 in (2 classes) to 0.32 in (20 and more); the
    numbers shrink with them and lose their decimal from 8 classes on, so
    that ``100.0`` always fits its cell.

    Examples
    --------
    >>> confusion_layout(2)
    (0.8, 11.0, '{:.1f}')
    >>> confusion_layout(12)
    (0.5, 7.0, '{:.0f}')
    """
    cell = float(np.clip(0.8 - 0.03 * (n - 2), 0.32, 0.8))
    size = float(np.clip(round(cell * 14.0), 5, 11))
    return cell, size, "{:.1f}" if n < 8 else "{:.0f}"


def confusion_figure(classes: Sequence[str], panels: Sequence[ConfusionPanel]) -> Any:
    """Draw confusion matrices (in %) side by side with one colour bar.

    Parameters
    ----------
    classes : sequence of str
        Class names, in matrix order; long names are wrapped.
    panels : sequence of (str, ndarray)
        Title and ``(n, n)`` matrix of each panel.

    Returns
    -------
    matplotlib.figure.Figure
        One axis per panel (plus the colour bar's), its cell font and size
        from :func:`confusion_layout`.
    """
    n = len(classes)
    cell, size, fmt = confusion_layout(n)
    names = [wrap(c, 12) for c in classes]
    ticks = min(9.0, size + 2.0)
    label_room = 0.09 * max(len(line) for c in names for line in c.split("\n")) + 0.6
    side = n * cell + label_room
    fig = new_figure(len(panels) * side + 1.0, side + 0.8)
    axes = fig.subplots(1, len(panels), squeeze=False)[0]
    image = None
    for ax, (title, percent) in zip(axes, panels, strict=True):
        image = ax.imshow(percent, vmin=0.0, vmax=100.0, cmap="Blues")
        for (i, j), value in np.ndenumerate(percent):
            ax.text(j, i, fmt.format(value), ha="center", va="center", fontsize=size,
                    color="white" if value > 60 else "black")  # fmt: skip
        ax.set_xticks(range(n), names, rotation=90 if n > 3 else 0, fontsize=ticks)
        ax.set_yticks(range(n), names, fontsize=ticks)
        ax.set_xlabel("predicted")
        ax.set_ylabel("true")
        ax.set_title(wrap(title, int(11 * side)), fontsize=10)  # ~11 characters per inch
    fig.colorbar(image, ax=list(axes), label="% of the true class", shrink=0.8)
    return fig
