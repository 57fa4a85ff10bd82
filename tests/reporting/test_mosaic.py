"""reporting.mosaic: frames with their region of interest, tile votes, label and truth."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.colors import to_rgba

from terrain_odom.reporting.mosaic import MosaicPanel, mosaic_figure


def _panel(truth: str, label: str = "gravel") -> MosaicPanel:
    image = np.full((120, 160, 3), 90, np.uint8)
    image[60:] = 180
    tiles = np.array([[40, 60, 80, 100], [80, 60, 120, 100]])
    polygon = np.array([[40.0, 110.0], [120.0, 110.0], [100.0, 60.0], [60.0, 60.0]])
    return MosaicPanel(7.5, image, label, 0.5, truth, "grass -> gravel confirmed",
                       (40, 60, 120, 110), polygon, tiles, ["gravel", "grass"])  # fmt: skip


@pytest.mark.parametrize(
    ("truth", "verdict", "colour"),
    [
        ("gravel", "right", "tab:green"),
        ("grass", "wrong", "tab:red"),
        ("", "truth unknown", "0.35"),
    ],
)
def test_a_panel_says_right_wrong_or_unknown_and_never_wrong_without_truth(truth, verdict, colour):
    panel = _panel(truth)
    assert panel.verdict == verdict
    (ax,) = [a for a in mosaic_figure([panel]).axes if a.images]
    assert ax.get_title().endswith(verdict)
    assert to_rgba(ax.title.get_color()) == to_rgba(colour)
    assert "truth unknown" in ax.get_title() or f"truth {truth}" in ax.get_title()


def test_mosaic_draws_each_frame_with_its_tiles_roi_and_a_legend(png_of, not_blank):
    panels = [_panel("gravel"), _panel(""), _panel("grass", "grass"), _panel("gravel")]
    fig = mosaic_figure(panels)
    images = [ax for ax in fig.axes if ax.images]
    assert len(images) == 4 and len(fig.axes) == 6  # 2 rows of 3, the last two empty
    ax = images[0]
    assert len(ax.patches) == 2 + 1 + 1  # two tiles, the box, the footprint polygon
    tile_colours = {to_rgba(p.get_facecolor())[:3] for p in ax.patches[:2]}
    assert len(tile_colours) == 2  # one colour per voted terrain
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert legend[:2] == ["tile vote: grass", "tile vote: gravel"]
    assert "region of interest (footprint)" in legend
    not_blank(png_of(fig))


def test_an_empty_mosaic_is_refused():
    with pytest.raises(ValueError, match="at least one frame"):
        mosaic_figure([])
