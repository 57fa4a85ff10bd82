"""Tests of ``terrain-odom train`` and ``terrain-odom report accuracy`` and their Python API.

Small synthetic image folders (tinted crops of skimage textures) exercise the
commands; the real floor photos of ``../shared/data/indoor_surface`` (next to
the repository, skipped when absent) check the accuracy acceptance.
"""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
import skimage.data

from terrain_odom.app.train import report_accuracy, train
from terrain_odom.cli.main import main
from terrain_odom.config.classifier import ClassifierConfig, paper_config
from terrain_odom.io.classifier_file import load_classifier
from terrain_odom.io.images import read_image_rgb

REPO = Path(__file__).resolve().parents[2]
SRC = REPO / "src"
TINTS = {"grass": (0.6, 1.0, 0.5), "gravel": (1.0, 0.9, 0.8), "brick": (1.0, 0.5, 0.4)}


def make_folder(root: Path, per_class: int = 6, sizes: tuple[int, ...] = (48, 48, 96)) -> Path:
    """``per_class`` tinted crops of each skimage texture, one sub-folder per class.

    Image ``i`` is ``sizes[i % len(sizes)]`` pixels square: by default every
    third image is 96 px (3x3 tiles with the defaults), the others 48 px (one tile).
    """
    for name, tint in TINTS.items():
        grey = getattr(skimage.data, name)()
        (root / name).mkdir(parents=True)
        for i in range(per_class):
            size = sizes[i % len(sizes)]
            crop = grey[(i // 4) * size : (i // 4 + 1) * size, (i % 4) * size : (i % 4 + 1) * size]
            rgb = np.clip(crop[..., None] * np.array(tint), 0, 255).astype(np.uint8)
            cv2.imwrite(str(root / name / f"{i}.png"), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    return root


def test_train_prints_counts_and_accuracy_and_writes_a_model(tmp_path, capsys):
    root = make_folder(tmp_path / "images")
    (root / "grass" / "broken.png").write_text("not an image")
    model_path = tmp_path / "model.npz"
    assert main(["train", "--images", str(root), "--out", str(model_path), "--jobs", "1"]) == 0
    out = capsys.readouterr().out
    assert "18 images: brick 6, grass 6, gravel 6" in out
    assert "skipped 1 image(s):" in out and "broken.png: cannot be read as an image" in out
    assert "5-fold cross-validated accuracy: mean" in out
    assert "confidence threshold " in out and "of held-out images reach it" in out
    assert f"model: {model_path}" in out
    model = load_classifier(model_path, expected=ClassifierConfig())
    assert model.n_training_images == 18
    # min_tile_size auto: the median shorter side (48 px) / 4 tiles = 12 px, recorded in the
    # model; 48 px and 96 px images both 4x4 tiles (with 32 px they were 1 and 3x3)
    assert model.config.min_tile_size == 12 and len(model.training_labels) == 18 * 16
    assert 0.0 <= model.min_confidence <= 1.0 and model.novelty_distance is not None
    label, confidence = model.classify(read_image_rgb(root / "brick" / "0.png"))
    assert label == "brick" and confidence > 0.5


def test_train_options_override_the_config_file(tmp_path, capsys):
    root = make_folder(tmp_path / "images", per_class=4)
    config = tmp_path / "c.yaml"
    config.write_text("classifier: {weights: uniform, k: 1}\n")
    args = ["train", "--images", str(root), "--out", str(tmp_path / "m"), "--jobs", "1"]
    args += [
        "--config",
        str(config),
        "--features",
        "sfta",
        "--no-scale",
        "--k",
        "3",
        "--tiles",
        "2",
        "--min-tile-size",
        "24",
    ]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "4-fold cross-validated" in out  # fewer images than 5 folds
    assert "tiles=2 min_tile_size=24" in out
    model = load_classifier(tmp_path / "m" / "classifier.npz")
    cfg = model.config
    assert (cfg.features, cfg.scale, cfg.k, cfg.tiles, cfg.min_tile_size, cfg.weights) == (
        "sfta",
        False,
        3,
        2,
        24,
        "uniform",
    )
    assert len(model.training_labels) == 3 * 4 * 2**2  # 2x2 tiles of every 48 and 96 px image


def test_train_api_returns_a_summary(tmp_path):
    root = make_folder(tmp_path / "images", per_class=5)
    summary = train(root, tmp_path / "m.npz", ClassifierConfig(k=3), jobs=1, progress=False)
    assert summary.counts == {"brick": 5, "grass": 5, "gravel": 5}
    assert summary.cross_validation.confusion.sum() == 15
    assert summary.classifier_path.is_file()


def test_report_accuracy_writes_json_csv_png_with_the_paper_configuration(tmp_path, capsys):
    root = make_folder(tmp_path / "images")
    out_dir = tmp_path / "report"
    argv = ["report", "accuracy", "--images", str(root), "--folds", "3", "--out", str(out_dir)]
    assert main([*argv, "--jobs", "1", "--k", "3", "--min-tile-size", "40"]) == 0
    printed = capsys.readouterr().out
    assert "3-fold cross-validation" in printed and "paper (Chen et al.)" in printed
    assert printed.count("mean accuracy") == 2
    report = json.loads((out_dir / "accuracy.json").read_text())
    assert (
        report["command"] == "report accuracy"
        and report["folds"] == 3
        and report["counts"] == {"brick": 6, "grass": 6, "gravel": 6}
    )
    chosen, paper = report["configurations"]["chosen"], report["configurations"]["paper"]
    assert chosen["config"]["k"] == 3 and chosen["config"]["scale"] is True
    assert chosen["config"]["min_tile_size"] == 40
    assert paper["config"]["features"] == "sfta" and paper["config"]["scale"] is False
    for entry in (chosen, paper):
        np.testing.assert_allclose(np.sum(entry["confusion_percent"], axis=1), 100.0)
        assert np.sum(entry["confusion_counts"]) == 18
        assert set(entry["feature_ms"]) == {"brick", "grass", "gravel"}
        assert entry["feature_ms"]["grass"]["max"] >= entry["feature_ms"]["grass"]["mean"] > 0
        diagonal = np.diag(entry["confusion_percent"])
        assert entry["mean_accuracy_percent"] == pytest.approx(diagonal.mean())
    with open(out_dir / "accuracy.csv", encoding="utf-8", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert [(r["configuration"], r["true_class"]) for r in rows[:4]] == [
        ("chosen", "brick"),
        ("chosen", "grass"),
        ("chosen", "gravel"),
        ("chosen", "mean"),
    ]
    assert len(rows) == 8 and float(rows[7]["accuracy_percent"]) == pytest.approx(
        paper["mean_accuracy_percent"], abs=0.01
    )
    assert (out_dir / "confusion.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_report_without_out_writes_nothing(tmp_path, capsys):
    root = make_folder(tmp_path / "images", per_class=3)
    report = report_accuracy(root, folds=3, jobs=1, progress=False)
    assert report.outputs == ()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["images"]
    assert report.paper.config == paper_config()


def run_process(*argv: str | Path) -> subprocess.CompletedProcess[str]:
    path = os.pathsep.join(filter(None, [str(SRC), os.environ.get("PYTHONPATH", "")]))
    return subprocess.run(
        [sys.executable, "-m", "terrain_odom", *map(str, argv)],
        env={**os.environ, "PYTHONPATH": path},
        capture_output=True,
        text=True,
        check=False,
    )


def test_single_class_is_one_line_exit_2_without_traceback(tmp_path):
    root = make_folder(tmp_path / "images", per_class=2)
    for name in ("gravel", "brick"):
        for path in (root / name).iterdir():
            path.unlink()
        (root / name).rmdir()
    proc = run_process("train", "--images", root, "--out", tmp_path / "m")
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr
    assert "at least 2 classes, found ['grass']" in proc.stderr


@pytest.mark.parametrize(
    ("extra", "fragment"),
    [
        (["--folds", "7"], "class 'brick' has 6 usable image(s)"),
        (["--k", "0"], "k: must be a whole number >= 1"),
        (["--config", "missing.yaml"], "missing.yaml: config file not found"),
    ],
)
def test_report_errors_exit_2(tmp_path, capsys, extra, fragment):
    root = make_folder(tmp_path / "images")
    assert main(["report", "accuracy", "--images", str(root), "--jobs", "1", *extra]) == 2
    err = capsys.readouterr().err
    assert err.startswith("terrain-odom: error:") and fragment in err


def test_train_errors_exit_2(tmp_path, capsys):
    root = make_folder(tmp_path / "images", per_class=2)
    (root / "asphalt").mkdir()
    args = ["train", "--images", str(root), "--jobs", "1", "--out"]
    assert main([*args, str(tmp_path / "m")]) == 2
    assert "class 'asphalt' has no images" in capsys.readouterr().err
    (root / "asphalt").rmdir()
    assert main([*args, str(tmp_path / "no" / "m.npz")]) == 2  # the old form: a file
    assert "m.npz: its folder does not exist" in capsys.readouterr().err
    (tmp_path / "file").write_text("")
    assert main([*args, str(tmp_path / "file")]) == 2
    assert "file: is a file, not an output folder" in capsys.readouterr().err
