"""Tests of ``terrain-odom train --tune`` and ``terrain-odom report accuracy --tune``.

A tiny folder (two classes of 32-px crops of skimage textures) and a grid of
two candidates keep each command to a second or two.
"""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import skimage.data

from terrain_odom.cli.main import main
from terrain_odom.io.classifier_file import load_classifier, load_tuning


def tiny_folder(root: Path, per_class: int = 6) -> Path:
    """``grass/`` and ``brick/``: ``per_class`` 32-px grey crops of each texture (PNG)."""
    for name in ("grass", "brick"):
        grey = getattr(skimage.data, name)()
        (root / name).mkdir(parents=True)
        for i in range(per_class):
            crop = grey[:32, 32 * i : 32 * (i + 1)]
            assert cv2.imwrite(str(root / name / f"{i}.png"), np.stack([crop] * 3, axis=-1))
    return root


def test_train_tune_prints_the_search_and_writes_a_tuned_model(tmp_path, capsys):
    images = tiny_folder(tmp_path / "images")
    grid = tmp_path / "grid.yaml"
    grid.write_text("k: [1, 3]\n")
    args = ["train", "--images", str(images), "--out", str(tmp_path / "m"), "--jobs", "1", "--tune"]
    out = tmp_path / "m" / "classifier.npz"
    assert main([*args, "--grid", str(grid), "--features", "sfta"]) == 0
    text = capsys.readouterr().out
    assert "tuned: 2 candidates of the grid, 5-fold cross-validated mean accuracy" in text
    assert "optimistic: the settings were chosen on these folds" in text
    tuning = load_tuning(out)
    assert tuning is not None and [c["params"] for c in tuning["candidates"]] == [
        {"k": 1},
        {"k": 3},
    ]
    assert load_classifier(out).config.k == tuning["choice"]["k"]
    assert load_classifier(out).config.features == "sfta"  # the options are the grid's base
    assert f"k={tuning['choice']['k']} " in text


def test_report_accuracy_tune_prints_each_fold_choice(tmp_path, capsys):
    images = tiny_folder(tmp_path / "images")
    grid = tmp_path / "grid.yaml"
    grid.write_text("- {k: [1]}\n- {k: [3], weights: [uniform]}\n")
    args = ["report", "accuracy", "--images", str(images), "--folds", "2", "--jobs", "1"]
    assert main([*args, "--grid", str(grid), "--out", str(tmp_path / "acc")]) == 0
    text = capsys.readouterr().out
    assert "tuned (nested: 2 candidates searched by 3-fold cross-validation" in text
    assert text.count("  fold ") == 2 and "this fold" in text
    report = json.loads((tmp_path / "acc" / "accuracy.json").read_text())
    assert len(report["tuned"]["folds"]) == 2 and report["tuned"]["inner_folds"] == 3


def test_a_bad_grid_is_one_line_and_exit_2(tmp_path, capsys):
    images = tiny_folder(tmp_path / "images", per_class=2)
    grid = tmp_path / "grid.yaml"
    grid.write_text("k: 3\n")
    args = ["train", "--images", str(images), "--out", str(tmp_path / "m"), "--grid", str(grid)]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.strip().count("\n") == 0 and "grid.k: expected a non-empty list" in err
    assert not (tmp_path / "m").exists()
