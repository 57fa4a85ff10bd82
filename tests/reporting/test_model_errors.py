"""reporting.model_errors: error per window against distance, and box plots per terrain."""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.evaluation.metrics import WindowErrors
from terrain_odom.evaluation.windows import Windows
from terrain_odom.reporting.model_errors import error_boxes_figure, window_errors_figure


def _errors(n: int, scale: float) -> WindowErrors:
    start = np.arange(n)
    windows = Windows(start, start + 1, np.full(n, 2.0))
    translation = scale * (1.0 + np.arange(n) % 5)  # m over 2 m windows
    return WindowErrors(windows, np.zeros((n, 3)), translation, np.radians(translation))


def test_window_errors_have_a_row_per_model_with_its_median_and_terrain_colours(png_of, not_blank):
    n = 100
    errors = {"idd": _errors(n, 0.2), "ekf": _errors(n, 0.02)}
    terrain = np.array(["grass"] * 50 + ["gravel"] * 50)
    fig = window_errors_figure(errors, np.arange(n) * 0.5, terrain, 2.0)
    assert len(fig.axes) == 4
    left, right = fig.axes[0], fig.axes[1]
    assert left.get_title(loc="left") == "idd"
    # translation per metre 0.1 * (1..5): median 0.3 m/m; rotation the same in degrees
    assert left.get_title(loc="right") == "median 0.3 m/m"
    assert right.get_title(loc="right") == "median 0.3 deg/m"
    assert left.lines[0].get_ydata()[0] == pytest.approx(0.3)
    assert fig.axes[2].get_xlabel().startswith("distance travelled") and left.get_yscale() == "log"
    points = left.collections[0]
    assert len(points.get_offsets()) == n
    assert len({tuple(c) for c in points.get_facecolors()}) == 2
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert legend == [
        "window starting on grass",
        "window starting on gravel",
        "median of the model",
    ]
    not_blank(png_of(fig))


def test_boxes_per_model_and_terrain_have_the_medians_of_the_values(png_of, not_blank):
    values = {
        "idd": {"grass": (np.array([0.1, 0.2, 0.3]), np.array([1.0, 2.0, 3.0]))},
        "ekf": {
            "grass": (np.array([0.01, 0.03]), np.array([0.1, 0.3])),
            "gravel": (np.array([0.05]), np.array([0.5])),
        },
    }
    fig = error_boxes_figure(values, 2.0)
    top, bottom = fig.axes
    assert top.get_ylabel() == "translational error (m/m)"
    assert bottom.get_ylabel() == "angular error (deg/m)"
    assert [t.get_text() for t in bottom.get_xticklabels()] == ["idd", "ekf"]
    medians = sorted(
        round(line.get_ydata()[0], 6) for line in top.lines if line.get_gid() == "median"
    )
    assert medians == [0.02, 0.05, 0.2]  # ekf grass, ekf gravel, idd grass
    assert [t.get_text() for t in top.get_legend().get_texts()] == ["grass", "gravel"]
    not_blank(png_of(fig))


def test_boxes_of_many_models_and_twelve_terrains_keep_their_labels_apart(apart):
    terrains = [f"terrain_{i:02d}" for i in range(12)]
    rng = np.random.default_rng(0)
    models = [f"model {i} with a rather long descriptive name (params_{i}.yaml)" for i in range(8)]
    values = {m: {t: (rng.random(20), rng.random(20)) for t in terrains} for m in models}
    fig = error_boxes_figure(values, 2.0)
    apart(fig, fig.axes[1].get_xticklabels())
    apart(fig, fig.axes[0].get_legend().get_texts())
