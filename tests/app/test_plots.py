"""app.plots: the plots every run and evaluation writes, drawn from the results in memory."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from terrain_odom.app import plots as app_plots
from terrain_odom.app.evaluate import evaluate
from terrain_odom.app.run import RunOptions, run
from terrain_odom.reporting.mosaic import MosaicPanel


def _image(path: Path) -> np.ndarray:
    image = cv2.imread(str(path))
    assert image is not None, f"{path} is not an image"
    grey = image.mean(axis=2)
    assert (grey < 250).mean() > 0.02 and grey.std() > 10  # not blank
    return image


def _relative(paths, out: Path) -> list[str]:
    return [p.relative_to(out).as_posix() for p in paths]


@pytest.fixture
def figures(monkeypatch: pytest.MonkeyPatch) -> dict:
    """Capture every figure written, by file name (and the mosaic's panels, as "panels")."""
    captured: dict = {}
    write, mosaic = app_plots.write_figures, app_plots.mosaic_figure

    def spy(folder, jobs):
        drawn = {name: draw() for name, draw in jobs.items()}
        captured.update(drawn)
        return write(folder, {name: (lambda fig=fig: fig) for name, fig in drawn.items()})

    def mosaic_spy(panels):
        captured["panels"] = list(panels)
        return mosaic(panels)

    monkeypatch.setattr(app_plots, "write_figures", spy)
    monkeypatch.setattr(app_plots, "mosaic_figure", mosaic_spy)
    return captured


def test_a_wheel_log_run_and_its_evaluation_draw_their_plots(examples_dir, tmp_path, figures):
    out = tmp_path / "out"
    log = examples_dir / "demo_log.csv"
    summary = run(log, out, RunOptions(config_path=examples_dir / "demo.yaml", progress=False))
    assert _relative(summary.plots, out) == ["plots/trajectory.png", "plots/states.png"]
    markdown = summary.report_md.read_text(encoding="utf-8")
    assert "(plots/trajectory.png)" in markdown and "(plots/states.png)" in markdown
    titles = [ax.get_title() for ax in figures["trajectory.png"].axes]
    assert titles[0] == "trajectory" and titles[1].startswith("position error")
    states = figures["states.png"].axes
    assert [ax.get_ylabel() for ax in states] == ["y_l (m)", "y_r (m)", "x_icr (m)", "alpha (-)"]
    legend = {t.get_text() for t in states[-1].get_legend().get_texts()}
    assert {"grass", "gravel", "covariance reset"} <= legend

    result = evaluate(out, log)
    assert _relative(result.plots, out) == [
        "plots/evaluation_windows.png",
        "plots/evaluation_boxes.png",
    ]
    for path in (*summary.plots, *result.plots):
        _image(path)
    windows = figures["evaluation_windows.png"].axes
    assert len(windows) == 2 * len(result.models)
    for ax, (name, model) in zip(windows[::2], result.models.items(), strict=True):
        assert ax.get_title(loc="left") == name
        assert ax.get_title(loc="right") == f"median {model.errors.translation.median:.3g} m/m"
        assert len(ax.collections[0].get_offsets()) == result.windows  # every window drawn
    boxes = figures["evaluation_boxes.png"].axes
    assert [t.get_text() for t in boxes[0].get_legend().get_texts()] == ["grass", "gravel"]
    assert [t.get_text() for t in boxes[1].get_xticklabels()] == list(result.models)


def test_a_real_warthog_log_run_and_evaluation_draw_their_plots(
    drive_dir, warthog_yaml, tmp_path, figures
):
    out = tmp_path / "out"
    log = drive_dir / "warthog_wheels_grass.csv"
    summary = run(log, out, RunOptions(config_path=warthog_yaml, progress=False))
    result = evaluate(out, log)
    names = [p.name for p in (*summary.plots, *result.plots)]
    assert names == [
        "trajectory.png",
        "states.png",
        "evaluation_windows.png",
        "evaluation_boxes.png",
    ]
    assert _image(out / "plots" / "trajectory.png").shape[1] == 9 * 110
    _, err = figures["trajectory.png"].axes
    distance, error = err.lines[0].get_data()
    assert 90 < distance[-1] < 110  # about 100 m driven
    assert np.median(error) < 0.1  # the filter follows the ICP poses it fuses
    assert len(figures["states.png"].axes) == 4
    assert len(figures["evaluation_windows.png"].axes) == 4  # idd and the run, m/m and deg/m


def test_the_camera_run_draws_the_mosaic_with_roi_votes_and_truth(sample_dir, tmp_path, figures):
    out = tmp_path / "out"
    summary = run(
        sample_dir / "log.csv",
        out,
        RunOptions(images=sample_dir, progress=False, groundtruth=sample_dir / "groundtruth.csv"),
    )
    names = [p.name for p in summary.plots]
    assert names == ["trajectory.png", "states.png", "frames.png", "mosaic.png"]
    for path in summary.plots:
        _image(path)
    images = [ax for ax in figures["mosaic.png"].axes if ax.images]
    assert len(images) == 2  # the two confirmed changes: to gravel, back to grass
    titles = [ax.get_title() for ax in images]
    assert "grass -> gravel confirmed" in titles[0] and "gravel -> grass confirmed" in titles[1]
    panels: list[MosaicPanel] = figures["panels"]
    assert [(p.label, p.truth, p.verdict) for p in panels] == [
        ("gravel", "gravel", "right"),
        ("grass", "grass", "right"),
    ]
    for panel in panels:
        assert panel.polygon is not None and len(panel.polygon) >= 3  # the run's box came out
        votes = list(panel.votes)
        assert max(set(votes), key=votes.count) == panel.label
        assert votes.count(panel.label) / len(votes) == pytest.approx(panel.confidence)
        x0, y0, x1, y1 = panel.box
        assert (panel.tiles[:, :2] >= [x0, y0]).all() and (panel.tiles[:, 2:] <= [x1, y1]).all()
    frames = figures["frames.png"].axes[0]
    lines = {line.get_label(): line for line in frames.lines}
    assert len(lines["label (wrong)"].get_xdata()) == 0  # the sample's frames are all right
    assert len(lines["label (truth unknown)"].get_xdata()) == 1  # the last looks past the end


def test_simulate_draws_the_map_with_axes(sim_output):
    assert sim_output.map_plot == sim_output.out_dir / "plots" / "map.png"
    image = _image(sim_output.map_plot)
    assert image.shape[1] == 8 * 110
    assert sim_output.to_dict()["map"]["plot"] == "plots/map.png"
