"""Tests of ``train(tune=True)`` and ``report_accuracy(tune=True)`` (:mod:`terrain_odom.app.tune`).

A small folder of two classes that differ only in colour (crops of skimage's
brick texture, one tinted without changing its grey levels) makes the right
choice known: colour features. The real floor photos of
``../shared/data/indoor_surface`` (skipped when absent) check a subset.
"""

from __future__ import annotations

import csv
import dataclasses
import json
from pathlib import Path

import cv2
import numpy as np
import pytest
import skimage.data

from terrain_odom.app.train import report_accuracy, train
from terrain_odom.app.tune import load_grid
from terrain_odom.config.classifier import ClassifierConfig
from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.io.classifier_file import load_classifier, load_tuning
from terrain_odom.vision.tuning import check_grid, default_grid

BASE = ClassifierConfig(n_t=1)
GRID = "features: [sfta, sfta+lab]\nk: [1, 3]\n"


def colour_folder(root: Path, per_class: int = 9) -> Path:
    """``neutral/`` grey and ``warm/`` tinted 32-px crops of brick, the same grey levels (PNG)."""
    grey = np.clip(skimage.data.brick(), 40, 230)
    for i in range(2 * per_class):
        g = grey[(i // 8) * 32 : (i // 8 + 1) * 32, (i % 8) * 32 : (i % 8 + 1) * 32].astype(int)
        name, rgb = ("warm", (g + 11, g, g - 30)) if i % 2 else ("neutral", (g, g, g))
        (root / name).mkdir(parents=True, exist_ok=True)
        bgr = np.stack(rgb[::-1], axis=-1).astype(np.uint8)
        assert cv2.imwrite(str(root / name / f"{i}.png"), bgr)
    return root


@pytest.fixture
def folder(tmp_path: Path) -> tuple[Path, Path]:
    """Return the colour folder and a grid file of 4 candidates (2 feature settings x k)."""
    grid = tmp_path / "grid.yaml"
    grid.write_text(GRID)
    return colour_folder(tmp_path / "images"), grid


def test_train_tune_chooses_colour_and_the_model_file_records_the_search(tmp_path, folder):
    images, grid = folder
    summary = train(images, tmp_path / "m", BASE, jobs=1, progress=False, grid_path=grid)
    tuning = summary.tuning
    assert tuning is not None and summary.config == tuning.chosen
    assert tuning.chosen.features == "sfta+lab" and tuning.chosen.n_t == 1  # base kept
    assert tuning.search.folds == 5 and len(tuning.search.candidates) == 4
    model = load_classifier(summary.classifier_path)
    assert model.config == tuning.chosen and model.n_training_images == 18
    stored = load_tuning(summary.classifier_path)
    assert stored == json.loads(json.dumps(tuning.to_dict()))
    assert stored["grid"] == [{"features": ["sfta", "sfta+lab"], "k": [1, 3]}]
    assert stored["choice"] == tuning.search.choice and stored["scoring"] == "balanced_accuracy"
    scores = {
        (c["params"]["features"], c["params"]["k"]): c["mean_percent"] for c in stored["candidates"]
    }
    assert scores["sfta+lab", 1] == scores["sfta+lab", 3] == 100.0
    assert max(scores["sfta", 1], scores["sfta", 3]) <= 75.0
    untuned = train(images, tmp_path / "plain", BASE, jobs=1, progress=False)
    assert untuned.tuning is None and load_tuning(untuned.classifier_path) is None  # old layout


def test_report_accuracy_tune_scores_the_tuning_by_nested_cross_validation(tmp_path, folder):
    images, grid = folder
    report = report_accuracy(
        images, BASE, folds=3, out_dir=tmp_path / "acc", jobs=1, progress=False, grid_path=grid
    )
    tuned = report.tuned
    assert tuned is not None and tuned.inner_folds == 3
    assert isinstance(tuned.base.min_tile_size, int)  # auto, chosen from the images' size
    assert tuned.base == dataclasses.replace(BASE, min_tile_size=tuned.base.min_tile_size)
    assert len(tuned.folds) == 3 and all(
        f.search.choice["features"] == "sfta+lab" for f in tuned.folds
    )
    test = np.sort(np.concatenate([f.test for f in tuned.folds]))
    assert np.array_equal(test, np.arange(18))  # every image scored once, by its outer fold
    cv = tuned.cross_validation  # pooled over the outer folds
    correct = sum(int(np.sum(f.truth == f.predicted)) for f in tuned.folds)
    assert cv.confusion.sum() == 18 and np.trace(cv.confusion) == correct
    assert cv.mean_accuracy >= 85.0  # 12 training images per outer fold
    assert [name for name, _ in report.configurations()] == ["chosen", "paper", "tuned"]
    saved = json.loads((tmp_path / "acc" / "accuracy.json").read_text())
    assert [f["choice"]["features"] for f in saved["tuned"]["folds"]] == ["sfta+lab"] * 3
    assert saved["tuned"]["mean_accuracy_percent"] == pytest.approx(cv.mean_accuracy)
    assert [f["accuracy_percent"] for f in saved["tuned"]["folds"]] == [
        f.accuracy for f in tuned.folds
    ]
    assert saved["tuned"]["grid"] == [{"features": ["sfta", "sfta+lab"], "k": [1, 3]}]
    rows = list(csv.DictReader((tmp_path / "acc" / "accuracy.csv").read_text().splitlines()))
    assert [r["true_class"] for r in rows if r["configuration"] == "tuned"] == [
        "neutral",
        "warm",
        "mean",
    ]
    assert (tmp_path / "acc" / "confusion.png").stat().st_size > 0


def test_the_untuned_report_is_unchanged_without_tune(tmp_path, folder):
    images, _ = folder
    report = report_accuracy(images, BASE, folds=3, jobs=1, progress=False)
    assert report.tuned is None and "tuned" not in report.to_dict()


def test_grid_files_are_checked_and_never_overwritten(tmp_path, folder):
    images, grid = folder
    assert load_grid(None, BASE, 48) == check_grid(default_grid(48), BASE)
    assert load_grid(grid, BASE) == [{"features": ["sfta", "sfta+lab"], "k": [1, 3]}]
    bad = tmp_path / "bad.yaml"
    bad.write_text("k: [1, 3]\ncolour: [lab]\n")
    with pytest.raises(ConfigError, match=f"{bad}: grid: unknown field 'colour'"):
        train(images, tmp_path / "m", grid_path=bad)
    with pytest.raises(ConfigError, match="grid file not found"):
        load_grid(tmp_path / "missing.yaml", BASE)
    odd = tmp_path / "grid.npz"  # a grid file the old --out FILE.npz form would name
    odd.write_text(GRID)
    with pytest.raises(InputFileError):
        train(images, odd, grid_path=odd)
    assert odd.read_text() == GRID


def test_too_few_images_for_the_nested_folds_is_an_input_error(tmp_path):
    images = colour_folder(tmp_path / "images", per_class=4)
    with pytest.raises(InputFileError, match="cannot nest 3-fold searches in 3 folds"):
        report_accuracy(images, BASE, folds=3, jobs=1, progress=False, tune=True)


def test_indoor_subset_nested_tuning(indoor_dir, tmp_path):
    # Every 10th photo (178 of 1,774), linked into a folder; a 4-candidate grid.
    for path in sorted(indoor_dir.glob("*/*"))[::10]:
        (tmp_path / "images" / path.parent.name).mkdir(parents=True, exist_ok=True)
        (tmp_path / "images" / path.parent.name / path.name).symlink_to(path)
    grid = tmp_path / "grid.yaml"
    grid.write_text("features: [sfta+lab, sfta+hsv]\nk: [5, 9]\n")
    report = report_accuracy(tmp_path / "images", folds=5, progress=False, grid_path=grid)
    assert sum(report.counts.values()) == 178
    tuned = report.tuned.cross_validation
    assert tuned.confusion.sum() == 178
    assert tuned.mean_accuracy >= 75.0
    assert report.paper.mean_accuracy < tuned.mean_accuracy - 10.0
