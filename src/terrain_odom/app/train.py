"""Terrain classifier training and accuracy reports: what ``train`` and ``report accuracy`` run.

Both read a labelled image folder (:mod:`terrain_odom.io.images`),
extract features in parallel and score the classifier by stratified k-fold
cross-validation over images (all tiles of an image stay in the same fold;
:mod:`~terrain_odom.vision.cross_validation`).
The accuracy report always scores Chen et al.'s own recipe
(:func:`~terrain_odom.config.classifier.paper_config`) on the same folds
beside the chosen configuration.
"""

from __future__ import annotations

import csv
import dataclasses
import datetime
import io
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

from terrain_odom.app.cluster import dask_cluster
from terrain_odom.app.locate import check_out, create_folder, output_file, writing_into
from terrain_odom.app.tune import (
    NestedTuning,
    Tuning,
    feature_cache,
    load_grid,
    nested_tuning,
    tune_settings,
)
from terrain_odom.config.classifier import ClassifierConfig, paper_config
from terrain_odom.errors import ConfigError
from terrain_odom.io.atomic import write_atomic, write_text_atomic
from terrain_odom.io.classifier_file import save_classifier
from terrain_odom.io.folder import writing_if
from terrain_odom.io.images import median_short_side, scan_image_folder
from terrain_odom.io.paths import check_outputs
from terrain_odom.io.report import report_header, write_json
from terrain_odom.reporting.confusion import confusion_figure
from terrain_odom.reporting.figure import save_png
from terrain_odom.vision.classifier import TerrainClassifier
from terrain_odom.vision.cross_validation import (
    CV_SEED,
    CrossValidation,
    cross_validate_images,
    feature_times_ms,
)
from terrain_odom.vision.dataset import LabelledImages, SkippedImage
from terrain_odom.vision.features import resolve_scale
from terrain_odom.vision.tuning import Grid, grid_configs

__all__ = [
    "MODEL_FILE",
    "MODEL_SUFFIXES",
    "TrainSummary",
    "AccuracyReport",
    "train",
    "report_accuracy",
]

MODEL_FILE = "classifier.npz"
"""The model file :func:`train` writes into its ``out_dir`` folder."""
MODEL_SUFFIXES = (".npz",)
"""Suffixes by which :func:`train`'s ``out_dir`` names the model file itself (the old form)."""

ACCURACY_FILES = ("accuracy.json", "accuracy.csv", "confusion.png")
"""Files :func:`report_accuracy` writes into its ``out_dir``."""


@dataclass(frozen=True)
class TrainSummary:
    """What :func:`train` did.

    Attributes
    ----------
    classifier_path : Path
    config : ClassifierConfig
    counts : dict of str to int
        Images used per class.
    skipped : tuple of SkippedImage
    cross_validation : CrossValidation or None
        None when a class has fewer than 2 images. With ``tuning``, of the
        chosen settings on the folds they were chosen on (optimistic). Its
        :meth:`~CrossValidation.threshold` is the model's ``min_confidence``
        (0 without cross-validation).
    tuning : Tuning or None
        The search of ``train(tune=True)`` (``config`` is its choice).
    """

    classifier_path: Path
    config: ClassifierConfig
    counts: dict[str, int]
    skipped: tuple[SkippedImage, ...]
    cross_validation: CrossValidation | None
    tuning: Tuning | None = None


def train(
    images: str | Path,
    out_dir: str | Path,
    config: ClassifierConfig | None = None,
    *,
    folds: int = 5,
    jobs: int | None = None,
    progress: bool | None = None,
    config_path: str | Path | None = None,
    tune: bool = False,
    grid_path: str | Path | None = None,
    dask: str | None = None,
) -> TrainSummary:
    """Train a terrain classifier on a labelled image folder and save it.

    Parameters
    ----------
    images : str or Path
        Folder with one sub-folder of images per terrain class.
    out_dir : str or Path
        Folder (created) to write the model file :data:`MODEL_FILE` into (see
        :func:`~terrain_odom.io.classifier_file.save_classifier`); a name
        ending in ``.npz`` is the model file itself (the old form).
    config : ClassifierConfig, optional
        Default: :class:`ClassifierConfig`.
    folds : int
        Cross-validation folds, reduced to the smallest class's image count.
    jobs : int, optional
        Feature-extraction processes (default: all usable cores).
    progress : bool, optional
        Progress bar (default: on a terminal only).
    config_path : str or Path, optional
        The file ``config`` was read from, an input ``out_dir`` must not overwrite.
    tune : bool
        Choose the settings of a grid around ``config`` by stratified
        ``folds``-fold cross-validation (:func:`~terrain_odom.app.tune.tune_settings`)
        and train with the choice; the model file records the grid, the
        scores and the choice.
    grid_path : str or Path, optional
        YAML grid for ``tune`` (:func:`~terrain_odom.app.tune.load_grid`;
        default :func:`~terrain_odom.vision.tuning.default_grid` around the
        images' size); implies ``tune``.
    dask : str, optional
        Run the feature extraction and the search on this Dask cluster
        (``tcp://host:port`` or ``local:N``, :func:`~terrain_odom.app.cluster.dask_cluster`;
        ``jobs`` is then the cluster's); the same result as without.

    Returns
    -------
    TrainSummary

    Raises
    ------
    InputFileError
        Missing folder, fewer than 2 classes, a class without usable images;
        ``out_dir`` is one of the images or ``config_path`` (checked first).
    ConfigError
        ``k`` larger than the number of training samples; an invalid grid.
    """
    config = ClassifierConfig() if config is None else config
    target = output_file(out_dir, MODEL_FILE, MODEL_SUFFIXES)
    check_out(out_dir, MODEL_SUFFIXES)
    tune = tune or grid_path is not None
    scan = scan_image_folder(images)
    config, grid = _scaled(config, scan, tune, grid_path)
    check_outputs([*scan.paths, config_path, grid_path], [target])
    with dask_cluster(dask) as cluster:
        jobs = jobs if cluster is None else cluster.jobs
        cache = feature_cache(scan, jobs, progress)
        tuning = (
            None if grid is None else tune_settings(cache, config, grid, folds=folds, jobs=jobs)
        )
        config = config if tuning is None else tuning.chosen
        data = cache.features(config)
    classifier = TerrainClassifier(config).fit(data.features, data.labels, data.region)
    folds = min(folds, *data.counts().values())
    validation = cross_validate_images(data, folds=folds) if folds >= 2 else None
    classifier.calibrate_novelty()
    threshold = None if validation is None else validation.threshold()
    classifier.min_confidence = 0.0 if threshold is None else threshold
    create_folder(out_dir, MODEL_SUFFIXES)
    with writing_into(out_dir, target, "train", [target.name], MODEL_SUFFIXES):
        save_classifier(classifier, target, tuning=None if tuning is None else tuning.to_dict())
    return TrainSummary(target, config, data.counts(), data.skipped, validation, tuning)


def _scaled(
    config: ClassifierConfig, scan: LabelledImages, tune: bool, grid_path: str | Path | None
) -> tuple[ClassifierConfig, Grid | None]:
    """``config`` with its ``auto`` settings chosen from the images' size, and the grid if ``tune``.

    The size is the images' median shorter side (:func:`~terrain_odom.io.images.median_short_side`);
    the default grid is built around it (:func:`~terrain_odom.app.tune.load_grid`).
    """
    short_side = median_short_side(scan.paths)
    if short_side is not None:
        config = resolve_scale(config, short_side)
    return config, load_grid(grid_path, config, short_side) if tune else None


@dataclass(frozen=True)
class AccuracyReport:
    """Cross-validated accuracy of a configuration and of Chen's recipe on the same folds.

    Attributes
    ----------
    images : Path
    chosen, paper : CrossValidation
    feature_ms : dict
        ``{"chosen" | "paper": {class: {"mean": ms, "max": ms}}}``.
    counts : dict of str to int
    skipped : tuple of SkippedImage
    outputs : tuple of Path
        Files written (empty without ``out_dir``).
    tuned : NestedTuning or None
        With ``tune``: the nested cross-validation of the settings tuned
        around ``chosen.config``, on the same outer folds.
    """

    images: Path
    chosen: CrossValidation
    paper: CrossValidation
    feature_ms: dict[str, dict[str, dict[str, float]]]
    counts: dict[str, int]
    skipped: tuple[SkippedImage, ...]
    outputs: tuple[Path, ...]
    tuned: NestedTuning | None = None

    def configurations(self) -> list[tuple[str, CrossValidation]]:
        """Return the scored configurations by name: chosen, paper (and tuned)."""
        out = [("chosen", self.chosen), ("paper", self.paper)]
        if self.tuned is not None:
            out.append(("tuned", self.tuned.cross_validation))
        return out

    def to_dict(self) -> dict[str, Any]:
        """Plain data for the JSON report."""
        return {
            **report_header("report accuracy"),
            "images": str(self.images),
            "folds": self.chosen.folds,
            "seed": CV_SEED,
            "classes": list(self.chosen.classes),
            "counts": self.counts,
            "skipped": [{"path": str(s.path), "reason": s.reason} for s in self.skipped],
            "configurations": {
                name: {**cv.to_dict(), "feature_ms": self.feature_ms[name]}
                for name, cv in (("chosen", self.chosen), ("paper", self.paper))
            },
            **({} if self.tuned is None else {"tuned": self.tuned.to_dict()}),
            "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        }


def report_accuracy(
    images: str | Path,
    config: ClassifierConfig | None = None,
    *,
    folds: int = 5,
    out_dir: str | Path | None = None,
    jobs: int | None = None,
    progress: bool | None = None,
    config_path: str | Path | None = None,
    tune: bool = False,
    grid_path: str | Path | None = None,
    dask: str | None = None,
) -> AccuracyReport:
    """Cross-validated confusion matrices of ``config`` and of Chen's recipe.

    Both are scored on the same stratified folds (seed :data:`~terrain_odom.vision.cross_validation.CV_SEED`).

    Parameters
    ----------
    images : str or Path
        Labelled image folder.
    config : ClassifierConfig, optional
        Configuration to score (default :class:`ClassifierConfig`).
    folds : int
    out_dir : str or Path, optional
        If given (an existing folder or one to create), write
        ``accuracy.json``, ``accuracy.csv`` and ``confusion.png`` there, each
        atomically.
    jobs, progress, config_path, tune, grid_path, dask
        As in :func:`train`; with ``tune``, the tuned classifier is scored
        by nested cross-validation (:func:`~terrain_odom.app.tune.nested_tuning`)
        on the same outer folds, beside ``config`` untuned.

    Returns
    -------
    AccuracyReport

    Raises
    ------
    InputFileError
        As :func:`train` (a file to write in ``out_dir`` is an input), or a
        class with fewer images than ``folds``; a file in ``out_dir`` it did
        not write (:mod:`terrain_odom.io.folder`).
    """
    config = ClassifierConfig() if config is None else config
    if folds < 2:
        raise ConfigError(f"folds: must be >= 2, got {folds}")
    out_dir = None if out_dir is None else Path(out_dir)
    scan = scan_image_folder(images)
    config, grid = _scaled(config, scan, tune or grid_path is not None, grid_path)
    if out_dir is not None:
        check_outputs(
            [*scan.paths, config_path, grid_path], [out_dir / name for name in ACCURACY_FILES]
        )
    with writing_if(out_dir, "report accuracy") as folder:  # locked; its own files replaced
        if folder is not None:
            folder.prepare(ACCURACY_FILES, overwrite=True, remove=False)
        report = _accuracy(Path(images), scan, config, grid, folds, jobs, dask, progress)
        if folder is None:
            return report
        folder.prepare(ACCURACY_FILES, overwrite=True)
        outputs = tuple(folder.path / name for name in ACCURACY_FILES)
        write_json(outputs[0], report.to_dict())
        write_text_atomic(outputs[1], accuracy_csv(report))
        write_atomic(outputs[2], lambda handle: plot_confusion(report, handle))
    return dataclasses.replace(report, outputs=outputs)


def _accuracy(
    images: Path,
    scan: LabelledImages,
    config: ClassifierConfig,
    grid: Grid | None,
    folds: int,
    jobs: int | None,
    dask: str | None,
    progress: bool | None,
) -> AccuracyReport:
    """Cross-validate ``config`` and Chen et al.'s recipe (and tune, with a grid) on ``images``."""
    paper = paper_config()
    with dask_cluster(dask) as cluster:
        jobs = jobs if cluster is None else cluster.jobs
        cache = feature_cache(scan, jobs, progress)
        cache.prepare([config, paper, *([] if grid is None else grid_configs(grid, config))])
        tuned = None if grid is None else nested_tuning(cache, config, grid, folds=folds, jobs=jobs)
    chosen_data, paper_data = cache.features(config), cache.features(paper)
    report = AccuracyReport(
        images=images,
        chosen=cross_validate_images(chosen_data, folds=folds),
        paper=cross_validate_images(paper_data, folds=folds),
        feature_ms={"chosen": feature_times_ms(chosen_data), "paper": feature_times_ms(paper_data)},
        counts=chosen_data.counts(),
        skipped=chosen_data.skipped,
        outputs=(),
        tuned=tuned,
    )
    return report


def accuracy_csv(report: AccuracyReport) -> str:
    """Return the report as CSV: one row per configuration and true class.

    Columns: ``configuration, true_class, images, predicted_<class>_percent``
    for each class (the row-normalised confusion matrix), ``accuracy_percent``,
    ``feature_ms_mean, feature_ms_max``; then one ``mean`` row per
    configuration with the mean per-class accuracy.
    """
    classes = report.chosen.classes
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(
        ["configuration", "true_class", "images"]
        + [f"predicted_{name}_percent" for name in classes]
        + ["accuracy_percent", "feature_ms_mean", "feature_ms_max"]
    )
    for name, cv in report.configurations():
        times = report.feature_ms.get(name)  # none for the tuned: its settings vary by fold
        for i, true in enumerate(classes):
            writer.writerow(
                [name, true, int(cv.confusion[i].sum())]
                + [f"{v:.2f}" for v in cv.percent[i]]
                + [f"{cv.percent[i, i]:.2f}"]
                + (
                    ["", ""]
                    if times is None
                    else [f"{times[true]['mean']:.3f}", f"{times[true]['max']:.3f}"]
                )
            )
        writer.writerow(
            [name, "mean", int(cv.confusion.sum())]
            + [""] * len(classes)
            + [f"{cv.mean_accuracy:.2f}", "", ""]
        )
    return buffer.getvalue()


def plot_confusion(report: AccuracyReport, handle: BinaryIO) -> None:
    """Draw the confusion matrices (chosen, paper, tuned) side by side as a PNG into ``handle``."""
    titles = {"chosen": "chosen", "paper": "paper (Chen et al.)", "tuned": "tuned (nested)"}
    panels = [
        (f"{titles[name]}: mean {cv.mean_accuracy:.1f} %", cv.percent)
        for name, cv in report.configurations()
    ]
    save_png(confusion_figure(report.chosen.classes, panels), handle, dpi=120)
