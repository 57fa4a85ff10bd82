"""The camera mosaic: the frame at each confirmed terrain change, its region of interest and votes."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from terrain_odom.reporting.figure import UNKNOWN, colour_of, new_figure, terrain_colours, wrap

__all__ = ["MosaicPanel", "mosaic_figure"]

_COLUMNS = 3


@dataclass(frozen=True)
class MosaicPanel:
    """One frame of the mosaic.

    Attributes
    ----------
    t : float
        Frame time, s.
    image : ndarray of uint8, shape (H, W, 3)
        The frame, RGB.
    label : str
        The frame's label (``""``: not classified).
    confidence : float
        Its vote share, 0-1.
    truth : str
        True terrain of the classified ground; ``""`` or ``"unknown"`` if not known.
    title : str
        What happened at the frame, e.g. ``"grass -> gravel confirmed"``.
    box : tuple of 4 int, optional
        Region of interest ``(x0, y0, x1, y1)``, px.
    polygon : ndarray, shape (M, 2), optional
        The visible footprint in the image, px.
    tiles : ndarray of int, shape (n, 4), optional
        Boxes of the tiles that voted, px in the image.
    votes : sequence of str
        Each tile's label.
    """

    t: float
    image: np.ndarray
    label: str
    confidence: float
    truth: str
    title: str
    box: tuple[int, int, int, int] | None = None
    polygon: np.ndarray | None = None
    tiles: np.ndarray | None = None
    votes: Sequence[str] = ()

    @property
    def verdict(self) -> str:
        """``"right"``, ``"wrong"``, or ``"truth unknown"``."""
        if not self.truth or self.truth == UNKNOWN:
            return "truth unknown"
        return "right" if self.label == self.truth else "wrong"


_VERDICT_COLOURS = {"right": "tab:green", "wrong": "tab:red", "truth unknown": "0.35"}


def _draw_panel(ax: Any, panel: MosaicPanel, colours: dict[str, str]) -> None:
    from matplotlib.patches import Polygon, Rectangle

    ax.imshow(panel.image, interpolation="antialiased")
    for (x0, y0, x1, y1), vote in zip(
        panel.tiles if panel.tiles is not None else [], panel.votes, strict=True
    ):
        colour = colour_of(colours, vote)
        ax.add_patch(Rectangle((x0 - 0.5, y0 - 0.5), x1 - x0, y1 - y0, fc=colour, ec=colour,
                               alpha=0.35, lw=1.0))  # fmt: skip
    if panel.box is not None:
        x0, y0, x1, y1 = panel.box
        ax.add_patch(Rectangle((x0 - 0.5, y0 - 0.5), x1 - x0, y1 - y0, fill=False, ec="white",
                               ls="--", lw=1.0))  # fmt: skip
    if panel.polygon is not None and len(panel.polygon):
        ax.add_patch(Polygon(panel.polygon, closed=True, fill=False, ec="yellow", lw=1.8))
    truth = panel.truth if panel.truth and panel.truth != UNKNOWN else UNKNOWN
    label = panel.label or "none"
    ax.set_title(
        f"t = {panel.t:.2f} s: {wrap(panel.title, 34)}\n"
        f"label {wrap(label, 16)} ({100 * panel.confidence:.0f} %), truth {wrap(truth, 16)}"
        f" - {panel.verdict}",
        fontsize=8,
        color=_VERDICT_COLOURS[panel.verdict],
    )
    ax.set_xticks([])
    ax.set_yticks([])


def mosaic_figure(panels: Sequence[MosaicPanel]) -> Any:
    """Frames in a grid: the region of interest (yellow polygon, white box), tile votes coloured.

    Each title gives the frame's label, vote share and true terrain: green
    when right, red when wrong, grey when the truth is unknown (never wrong).

    Parameters
    ----------
    panels : sequence of MosaicPanel
        At least one.

    Returns
    -------
    matplotlib.figure.Figure
        One image axis per panel, and a legend of the terrain colours.
    """
    if not panels:
        raise ValueError("a mosaic needs at least one frame")
    columns = min(_COLUMNS, len(panels))
    rows = math.ceil(len(panels) / columns)
    height, width = panels[0].image.shape[:2]
    panel_w = 3.4
    fig = new_figure(panel_w * columns, rows * (panel_w * height / width + 0.75) + 0.5)
    grid = fig.subplots(rows, columns, squeeze=False)
    votes = [v for p in panels for v in (*p.votes, p.label, p.truth)]
    colours = terrain_colours(votes)
    for ax, panel in zip(grid.ravel(), panels, strict=False):
        _draw_panel(ax, panel, colours)
    for ax in grid.ravel()[len(panels) :]:
        ax.set_axis_off()
    _legend(fig, colours)
    return fig


def _legend(fig: Any, colours: dict[str, str]) -> None:
    """Put the tile-vote colours and the region outlines in a legend under the grid."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles: list[Any] = [Patch(fc=c, alpha=0.5) for c in colours.values()]
    labels = [f"tile vote: {wrap(n, 16)}" for n in colours]
    handles += [Line2D([], [], color="yellow", lw=1.8), Line2D([], [], color="0.4", ls="--")]
    labels += ["region of interest (footprint)", "its bounding box"]
    fig.legend(handles, labels, loc="outside lower center", ncol=min(4, len(handles)),
               fontsize=8, frameon=False)  # fmt: skip
