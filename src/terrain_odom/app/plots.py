"""The PNG plots of a run, drawn from what the run holds in memory (not by re-reading its files).

:func:`write_run_plots` draws every run's trajectory and states, and with
camera frames the mosaic of the frames at each confirmed terrain change
(re-classified tile by tile to show the votes); with ground truth also the
frame labels against the truth. Files go to ``OUT/plots/``, each atomically.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from terrain_odom.app.frames import FrameRecord
from terrain_odom.app.groundtruth import GroundTruthReport
from terrain_odom.config import Config
from terrain_odom.estimation.odometry import OdometryResult
from terrain_odom.evaluation.metrics import WindowErrors
from terrain_odom.evaluation.windows import wheel_path
from terrain_odom.io.atomic import write_atomic
from terrain_odom.io.images import read_image_rgb
from terrain_odom.records import GroundTruth, WheelLog
from terrain_odom.reporting.figure import save_png
from terrain_odom.reporting.model_errors import (
    ErrorValues,
    error_boxes_figure,
    error_values,
    window_errors_figure,
)
from terrain_odom.reporting.mosaic import MosaicPanel, mosaic_figure
from terrain_odom.reporting.outage import Outages, outage_figure
from terrain_odom.reporting.plots import (
    frame_labels_figure,
    states_figure,
    trajectory_figure,
    travelled,
)
from terrain_odom.vision.camera import GroundCamera, crop, region_of_interest
from terrain_odom.vision.frame_classifier import FULL_FRAME

if TYPE_CHECKING:  # scikit-learn and the feature code load for camera runs' mosaics only
    from terrain_odom.vision.classifier import TerrainClassifier

__all__ = [
    "PLOTS_DIR",
    "PLOT_FILES",
    "EVALUATION_PLOTS",
    "MOSAIC_FRAMES",
    "write_figures",
    "write_run_plots",
    "mosaic_panels",
    "with_votes",
    "measured_distance",
    "write_evaluation_plots",
]

PLOTS_DIR = "plots"
"""Folder of a run's plots, in its output folder."""

PLOT_FILES = ("trajectory.png", "states.png", "frames.png", "mosaic.png")
"""Every plot a run may write into :data:`PLOTS_DIR`."""

EVALUATION_PLOTS = ("evaluation_windows.png", "evaluation_boxes.png", "evaluation_outages.png")
"""The plots ``evaluate`` writes into :data:`PLOTS_DIR` beside its JSON (the last with outages)."""

ALL_TERRAINS = "all windows"
"""The one group of the box plots of a log without terrain labels."""

MOSAIC_FRAMES = 12
"""Most frames in the mosaic (evenly chosen among the changes when there are more)."""

Draw = Callable[[], Any]


def write_figures(folder: Path, jobs: dict[str, Draw]) -> list[Path]:
    """Draw each figure of ``jobs`` (file name to a function returning it) into ``folder``.

    Each PNG is written atomically; the folder is created. Returns the paths written.
    """
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for name, draw in jobs.items():
        write_atomic(folder / name, functools.partial(save_png, draw()))
        written.append(folder / name)
    return written


def write_run_plots(
    out_dir: Path,
    log: WheelLog,
    result: OdometryResult,
    config: Config,
    *,
    truth: GroundTruth | None = None,
    scored: GroundTruthReport | None = None,
    records: Sequence[FrameRecord] = (),
    images: Path | None = None,
    classifier: TerrainClassifier | None = None,
) -> list[str]:
    """Write the plots of a run into ``out_dir/plots``; return their paths relative to ``out_dir``.

    Parameters
    ----------
    out_dir : Path
        The run's output folder.
    log, result, config
        The run's (calibrated) log, its result and configuration.
    truth, scored : optional
        Ground truth and the run scored against it (its filter variants and
        the true terrain of each frame).
    records, images, classifier : optional
        The frames of a camera run, their folder and the classifier: the mosaic.

    Returns
    -------
    list of str
        ``plots/trajectory.png``, ``plots/states.png``, and with frames
        ``plots/mosaic.png`` (and with ground truth ``plots/frames.png``).
    """
    variants = scored.results if scored is not None else None
    jobs: dict[str, Draw] = {
        "trajectory.png": lambda: trajectory_figure(log, result, truth=truth, variants=variants),
        "states.png": lambda: states_figure(log.t, result, truth=truth, starts=log.run_starts()),
    }
    frame_truth = None if scored is None else scored.frame_truth
    if records and frame_truth is not None:
        t = np.array([r.t for r in records], dtype=float)
        jobs["frames.png"] = lambda: frame_labels_figure(
            t, [r.label for r in records], [str(v) for v in frame_truth]
        )
    if records and images is not None and classifier is not None:
        panels = mosaic_panels(records, result, log, config, classifier, images, frame_truth)
        if panels:
            jobs["mosaic.png"] = lambda: mosaic_figure(panels)
    written = write_figures(out_dir / PLOTS_DIR, jobs)
    return [path.relative_to(out_dir).as_posix() for path in written]


def _picks(records: Sequence[FrameRecord], result: OdometryResult) -> list[tuple[int, str]]:
    """Frames to show: the one confirming each change (record index, title)."""
    times = np.array([r.t for r in records], dtype=float)
    picks = []
    for change in result.changes:
        when = change.t if change.t_confirmed is None else change.t_confirmed
        index = int(np.searchsorted(times, when + 1e-9, side="right")) - 1
        if index >= 0:
            previous = change.previous or "start"
            picks.append((index, f"{previous} -> {change.label} confirmed"))
    if not picks:
        labelled = [i for i, r in enumerate(records) if r.label]
        if labelled:
            picks = [(labelled[0], "first frame (no change confirmed)")]
    if len(picks) > MOSAIC_FRAMES:
        keep = np.linspace(0, len(picks) - 1, MOSAIC_FRAMES).round().astype(int)
        picks = [picks[i] for i in keep]
    return picks


def mosaic_panels(
    records: Sequence[FrameRecord],
    result: OdometryResult,
    log: WheelLog,
    config: Config,
    classifier: TerrainClassifier,
    images: Path,
    frame_truth: np.ndarray | None = None,
) -> list[MosaicPanel]:
    """Return the mosaic's panels: the frame confirming each terrain change.

    The region of interest is computed again from the wheel speeds and ICR
    estimate the frame met (the run's rows), and its tiles classified one by
    one to show their votes; a region that does not come out as the run's box
    (it should always) is drawn as the box alone, without votes. Frames that
    cannot be read are left out.
    """
    panels = []
    for index, title in _picks(records, result):
        record = records[index]
        image = read_image_rgb(images / record.file)
        if image is None:
            continue
        truth = "" if frame_truth is None else str(frame_truth[index])
        panel = MosaicPanel(record.t, image, record.label, record.confidence, truth, title,
                            box=record.box)  # fmt: skip
        panels.append(with_votes(panel, record, result, log, config, classifier))
    return panels


def with_votes(
    panel: MosaicPanel,
    record: FrameRecord,
    result: OdometryResult,
    log: WheelLog,
    config: Config,
    classifier: TerrainClassifier,
) -> MosaicPanel:
    """Add the footprint polygon and the tiles' votes to a panel (see :func:`mosaic_panels`)."""
    from terrain_odom.vision.features import image_features, tile_boxes, tiles_within

    image = panel.image
    if record.box is None:
        return panel
    polygon = None
    region = image
    if record.roi_status != FULL_FRAME:
        row = max(0, int(np.searchsorted(log.t, record.t, side="right")) - 1)
        names = list(result.names)
        params = result.states[row, [names.index(n) for n in ("y_l", "y_r", "x_icr")]]
        if "alpha" in names:
            params = np.append(params, result.states[row, names.index("alpha")])
        roi = region_of_interest(GroundCamera(config.camera), config.roi, log.v_l[row], log.v_r[row],
                                 params)  # fmt: skip
        if roi.box != record.box:
            return panel
        polygon = roi.image_polygon
        region = crop(image, roi)
    x0, y0 = record.box[:2]
    footprint = None if polygon is None else polygon - np.array([x0, y0], dtype=float)
    height, width = region.shape[:2]
    boxes = tile_boxes(height, width, classifier.config)
    if footprint is not None:
        boxes = boxes[tiles_within(height, width, classifier.config, footprint)]
    votes = classifier.predict(image_features(region, classifier.config, footprint))
    offset = np.array([x0, y0, x0, y0])
    return replace(panel, polygon=polygon, tiles=boxes + offset, votes=[str(v) for v in votes])


def measured_distance(log: WheelLog) -> np.ndarray:
    """Return the distance travelled along the measured positions at each row, m (NaN between).

    Steps between segments count as zero (their poses need not join).
    """
    rows = np.flatnonzero(log.has_position)
    runs = log.segment_runs()[rows]
    breaks = np.flatnonzero(np.diff(runs) != 0) + 1
    distance = np.full(len(log), np.nan)
    distance[rows] = travelled(log.pose[rows, :2], breaks)
    return distance


def _by_terrain(errors: WindowErrors, terrain: np.ndarray | None) -> dict[str, ErrorValues]:
    """Per-metre errors grouped by the terrain of each window's start row."""
    values = error_values(errors)
    if terrain is None:
        return {ALL_TERRAINS: values}
    start = np.asarray(terrain).astype(str)[errors.windows.start]
    return {str(g): (values[0][start == g], values[1][start == g]) for g in np.unique(start)}


def write_evaluation_plots(
    folder: Path,
    log: WheelLog,
    errors: dict[str, WindowErrors],
    horizon: float,
    outages: Outages | None = None,
) -> list[Path]:
    """Write the plots of ``evaluate`` into ``folder``; return their paths.

    ``evaluation_windows.png``: each model's error per metre, window by
    window, against the distance travelled (coloured by the log's terrain),
    with its median; ``evaluation_boxes.png``: box plots per model and terrain;
    with ``outages``, ``evaluation_outages.png``
    (:func:`~terrain_odom.reporting.outage.outage_figure`).

    Parameters
    ----------
    folder : Path
        Created if needed.
    log : WheelLog
        The evaluated log.
    errors : dict of str to WindowErrors
        Per model, its errors on the ``horizon`` windows (all, not decimated:
        only the drawing is).
    horizon : float
        ``h_e``, m.
    outages : Outages, optional
        Per duration, per model: outage-window errors.
    """
    # without full poses (a GPS's fixes, or none) the windows are as long as the wheels say
    distance = measured_distance(log) if log.has_pose.any() else wheel_path(log)
    grouped = {name: _by_terrain(e, log.terrain) for name, e in errors.items()}
    windows_png, boxes_png, outages_png = EVALUATION_PLOTS
    jobs = {
        windows_png: lambda: window_errors_figure(errors, distance, log.terrain, horizon),
        boxes_png: lambda: error_boxes_figure(grouped, horizon),
    }
    if outages:
        jobs[outages_png] = lambda: outage_figure(outages)
    return write_figures(folder, jobs)
