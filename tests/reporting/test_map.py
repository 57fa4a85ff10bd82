"""reporting.map: the simulated ground in metres with the path by terrain."""

from __future__ import annotations

import numpy as np

from terrain_odom.reporting.map import map_figure


def test_map_has_metre_axes_on_the_map_extent_and_the_path_by_terrain(png_of, not_blank):
    image = np.zeros((50, 100, 3), np.uint8)
    image[:, 50:] = 200
    xy = np.column_stack([np.linspace(0.0, 8.0, 9), np.zeros(9)])
    terrain = ["grass"] * 5 + ["gravel"] * 4
    fig = map_figure(image, (-2.0, 18.0, -5.0, 5.0), xy, terrain)
    (ax,) = fig.axes
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("x (m)", "y (m)")
    assert ax.images[0].get_extent() == [-2.0, 18.0, -5.0, 5.0]
    assert ax.get_aspect() == 1.0
    lines = {line.get_label(): line for line in ax.lines}
    grass = lines["path on grass"].get_xdata()
    assert np.isfinite(grass).sum() == 5 and grass[4] == 4.0
    assert np.isfinite(lines["path on gravel"].get_xdata()).sum() == 4
    assert lines["start"].get_xdata()[0] == 0.0 and lines["end"].get_xdata()[0] == 8.0
    not_blank(png_of(fig))
