"""The map of a simulated run: the ground in metres, with the true path coloured by terrain."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from terrain_odom.reporting.figure import colour_of, decimate, new_figure, terrain_colours, wrap

__all__ = ["map_figure"]


def map_figure(
    image: np.ndarray,
    extent: Sequence[float],
    xy: np.ndarray,
    terrain: Sequence[str] | np.ndarray,
) -> Any:
    """Draw the ground map with metre axes and the path on it.

    Parameters
    ----------
    image : ndarray, shape (H, W, 3)
        The map, RGB, north (``+y``) up.
    extent : sequence of 4 float
        ``x_min, x_max, y_min, y_max`` of the map, m.
    xy : ndarray, shape (N, 2)
        The true path, m.
    terrain : sequence of str, shape (N,)
        Terrain under the robot along the path (the path's colour).

    Returns
    -------
    matplotlib.figure.Figure
        One axis, ``x (m)`` and ``y (m)``, equal scale.
    """
    from matplotlib import patheffects

    x_min, x_max, y_min, y_max = (float(v) for v in extent)
    ratio = float(np.clip((y_max - y_min) / max(x_max - x_min, 1e-9), 0.25, 2.0))
    fig = new_figure(8.0, 1.2 + 5.6 * ratio)
    ax = fig.subplots()
    ax.imshow(
        image, extent=(x_min, x_max, y_min, y_max), origin="upper", interpolation="antialiased"
    )
    index = decimate(len(xy))
    labels = np.asarray(terrain).astype(str)[index]
    colours = terrain_colours(labels)
    path = xy[index]
    halo = [patheffects.withStroke(linewidth=5.0, foreground="white")]
    for name in colours:
        masked = np.where((labels == name)[:, None], path, np.nan)
        ax.plot(*masked.T, color=colours[name], lw=2.5, label=f"path on {wrap(name, 20)}",
                path_effects=halo)  # fmt: skip
    if not colours:
        ax.plot(*path.T, color=colour_of(colours, ""), lw=2.5, label="path", path_effects=halo)
    ax.plot(*path[0], "o", ms=9, mfc="white", mec="black", mew=1.5, label="start")
    ax.plot(*path[-1], "s", ms=8, color="black", label="end")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal")
    ax.set_title("simulated ground and the true path")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    return fig
