"""reporting.plots: the run's figures, checked through their axes and their pixels."""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.estimation.odometry import OdometryResult
from terrain_odom.records import GroundTruth, TerrainChange, WheelLog
from terrain_odom.reporting.figure import MAX_POINTS
from terrain_odom.reporting.plots import frame_labels_figure, states_figure, trajectory_figure

NAMES = ("x", "y", "yaw", "y_l", "y_r", "x_icr", "alpha")


def _run(n: int = 400, labels: tuple[str, ...] = ("grass", "gravel"), offset: float = 0.1):
    """Return a circle driven at 1 m/s: poses every 10th row, the estimate ``offset`` m left."""
    t = np.arange(n) * 0.05
    angle = t / 5.0
    truth = np.column_stack([5 * np.sin(angle), 5 - 5 * np.cos(angle), angle])
    pose = np.full((n, 3), np.nan)
    pose[::10] = truth[::10]
    terrain = np.array([labels[min(len(labels) - 1, i * len(labels) // n)] for i in range(n)])
    log = WheelLog(t, np.full(n, 0.9), np.full(n, 1.1), pose, terrain, np.zeros(n, int))
    states = np.zeros((n, len(NAMES)))
    states[:, :3] = truth
    states[:, 1] += offset
    states[:, 3:] = [0.4, -0.4, 0.05, 0.95]
    stds = np.full((n, len(NAMES)), 0.1)
    changes = [TerrainChange(float(t[n // 2]), "grass", "gravel", restored=False)]
    return log, OdometryResult(NAMES, states, stds, terrain, changes), truth


def _axis_titles(fig):
    return [ax.get_title() for ax in fig.axes]


def test_trajectory_has_the_path_by_terrain_poses_marks_and_the_error_against_distance(
    png_of, not_blank
):
    log, result, _ = _run()
    fig = trajectory_figure(log, result)
    assert len(fig.axes) == 2
    ax, err = fig.axes
    assert ax.get_title() == "trajectory"
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("x (m)", "y (m)")
    assert ax.get_aspect() == 1.0
    labels = ax.get_legend_handles_labels()[1]
    for name in ("measured poses", "estimate on grass", "estimate on gravel", "start", "end"):
        assert name in labels
    colours = {tuple(c) for c in ax.collections[0].get_colors()}
    assert len(colours) == 2  # one per terrain
    assert err.get_xlabel().startswith("distance travelled") and "(m)" in err.get_ylabel()
    distance, error = err.lines[0].get_data()
    np.testing.assert_allclose(error, 0.1, atol=1e-12)  # the estimate is 0.1 m off every pose
    np.testing.assert_allclose(distance[1], 10 * 0.05 * 1.0, rtol=1e-3)  # 1 m/s, 10 rows apart
    not_blank(png_of(fig))


def test_trajectory_without_poses_has_one_panel_and_truth_and_variants_get_distinct_styles():
    log, result, truth_xy = _run()
    bare = WheelLog(log.t, log.v_l, log.v_r, np.full_like(log.pose, np.nan), None, log.segment)
    assert len(trajectory_figure(bare, result).axes) == 1
    truth = GroundTruth(log.t, truth_xy, np.zeros((len(log), 3)), None, log.terrain, "gt")
    fig = trajectory_figure(bare, result, truth=truth, variants={"a": result, "b": result})
    ax, err = fig.axes
    styles = {(str(line.get_color()), str(line.get_linestyle())) for line in ax.lines[-2:]}
    assert len(styles) == 2
    assert "ground truth" in err.get_title()
    assert [line.get_label() for line in err.lines] == ["estimate", "a", "b"]


def test_a_million_rows_are_drawn_decimated(png_of):
    log, result, _ = _run(n=1_000_000)
    fig = trajectory_figure(log, result)
    png_of(fig)
    states = states_figure(log.t, result)
    png_of(states)
    for line in fig.axes[1].lines + states.axes[0].lines:
        assert len(line.get_xdata()) <= MAX_POINTS + 2


def test_states_have_bands_of_two_sigma_terrain_spans_and_the_reset(png_of, not_blank):
    log, result, _ = _run()
    fig = states_figure(log.t, result)
    assert [ax.get_ylabel() for ax in fig.axes] == ["y_l (m)", "y_r (m)", "x_icr (m)", "alpha (-)"]
    assert fig.axes[-1].get_xlabel() == "t (s)"
    ax = fig.axes[0]
    band = [c for c in ax.collections if c.get_label() == "estimate ± 2σ"][0]
    y = band.get_paths()[0].vertices[:, 1]
    assert y.min() == pytest.approx(0.4 - 0.2) and y.max() == pytest.approx(0.4 + 0.2)
    spans = [p for p in ax.patches]
    assert len(spans) == 2  # grass, then gravel
    resets = [line for line in ax.lines if line.get_xdata()[0] == result.changes[0].t]
    assert len(resets) == 1
    legend = fig.axes[-1].get_legend()
    texts = [t.get_text() for t in legend.get_texts()]
    assert {"grass", "gravel", "covariance reset", "estimate ± 2σ"} <= set(texts)
    not_blank(png_of(fig))


def test_states_of_twelve_terrains_with_long_names_keep_their_legend_apart(
    png_of, not_blank, apart
):
    names = tuple(f"terrain_with_a_long_name_{i:02d}" for i in range(12))
    log, result, _ = _run(n=1200, labels=names)
    fig = states_figure(log.t, result)
    apart(fig, fig.axes[-1].get_legend().get_texts())
    not_blank(png_of(fig))


def test_frames_of_unknown_truth_are_shown_as_unknown_never_as_wrong(png_of, not_blank):
    t = np.arange(6.0)
    truth = ["grass", "grass", "gravel", "gravel", "", "unknown"]
    labels = ["grass", "gravel", "gravel", "gravel", "grass", "gravel"]
    fig = frame_labels_figure(t, labels, truth)
    (ax,) = fig.axes
    lines = {line.get_label(): line for line in ax.lines}
    assert lines["label (wrong)"].get_xdata().tolist() == [1.0]
    assert lines["label (right)"].get_xdata().tolist() == [0.0, 2.0, 3.0]
    assert lines["label (truth unknown)"].get_xdata().tolist() == [4.0, 5.0]
    assert [t.get_text() for t in ax.get_yticklabels()] == ["grass", "gravel"]
    image = png_of(fig)
    not_blank(image)
    b, g, r = (image[..., i].astype(int) for i in range(3))
    assert ((r > 200) & (g < 80) & (b < 80)).any()  # the red cross of the wrong label


def _drawn_within_picture(fig) -> bool:
    """Whether everything a drawn ``fig`` shows (labels, ticks, legends) lies in its picture."""
    drawn = fig.get_tightbbox(fig.canvas.get_renderer())  # inches
    width, height = fig.get_size_inches()
    slack = 1.0 / fig.dpi  # a pixel
    return bool(drawn.x0 >= -slack and drawn.y0 >= -slack and drawn.x1 <= width + slack
                and drawn.y1 <= height + slack)  # fmt: skip


def test_the_run_figures_lay_out_long_labels_and_large_coordinates_inside_the_picture(png_of):
    """Laid out when drawn (every run draws these two): no legend, tick or label is cut off."""
    names = tuple(f"terrain_with_a_long_name_{i:02d}" for i in range(5))
    log, result, truth_xy = _run(n=1200, labels=names)
    far = np.array([452_310.0, 5_411_870.0, 0.0])  # UTM-sized coordinates: long tick labels
    log = WheelLog(log.t, log.v_l, log.v_r, log.pose + far, log.terrain, log.segment)
    result = OdometryResult(NAMES, result.states + np.append(far, np.zeros(4)), result.stds,
                            result.terrain, result.changes)  # fmt: skip
    truth = GroundTruth(log.t, truth_xy + far, np.zeros((len(log), 3)), None, log.terrain, "gt")
    variants = {"ICR EKF without the terrain-triggered reset": result, "b": result}
    for fig in (trajectory_figure(log, result, truth=truth, variants=variants),
                states_figure(log.t, result)):  # fmt: skip
        assert fig.get_layout_engine() is not None  # laid out when drawn
        png_of(fig)
        assert _drawn_within_picture(fig)
