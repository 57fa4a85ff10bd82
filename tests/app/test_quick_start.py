"""The camera quick start: the committed sample run and the default classifier.

``terrain-odom run --images sample_images/chen2023 --wheels
sample_images/chen2023/log.csv --out out/`` needs neither ``--classifier`` (the
default model, package data ``terrain_odom/models/default.npz``) nor
``--config`` (the run folder's ``config.yaml``).
"""

from __future__ import annotations

import csv
import importlib.util
import json
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from terrain_odom.app import run as workflows
from terrain_odom.app.inputs import DEFAULT, IN_IMAGES
from terrain_odom.cli.main import main
from terrain_odom.io import classifier_file
from terrain_odom.io.classifier_file import load_classifier

REPO = Path(__file__).resolve().parents[2]
SAMPLE = REPO / "sample_images" / "chen2023"
MODEL = REPO / "src" / "terrain_odom" / "models" / "default.npz"


def _module(path: Path):
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def _true_changes() -> list[tuple[float, str]]:
    rows = _rows(SAMPLE / "groundtruth.csv")
    return [
        (float(b["t"]), b["terrain"])
        for a, b in zip(rows, rows[1:], strict=False)
        if a["terrain"] != b["terrain"]
    ]


def _short_copy(tmp_path: Path, seconds: float = 3.0, config: bool = False) -> Path:
    """Copy the sample's first ``seconds`` (frames and log) to ``tmp_path/images``."""
    images = tmp_path / "images"
    (images / "frames").mkdir(parents=True)
    rows = [r for r in _rows(SAMPLE / "frames.csv") if float(r["t"]) <= seconds]
    for row in rows:
        shutil.copy(SAMPLE / row["file"], images / row["file"])
    (images / "frames.csv").write_text(
        "t,file\n" + "".join(f"{r['t']},{r['file']}\n" for r in rows), encoding="utf-8"
    )
    lines = (SAMPLE / "log.csv").read_text(encoding="utf-8").splitlines()
    (images / "log.csv").write_text("\n".join(lines[: int(seconds * 50) + 2]) + "\n")
    if config:
        shutil.copy(SAMPLE / "config.yaml", images / "config.yaml")
    return images


def test_quick_start_on_the_sample_needs_no_model_and_no_config(sample_camera_run):
    out, printed = sample_camera_run
    assert f"report:     {out / 'report.json'}" in printed
    assert f"config:     {SAMPLE / 'config.yaml'}" in printed
    assert f"model:      {MODEL.resolve()}" in printed
    report = json.loads((out / "report.json").read_text())
    assert report["terrain_source"] == "camera"
    assert report["inputs"]["config"] == str((SAMPLE / "config.yaml").resolve())
    assert report["inputs"]["model"] == str(MODEL.resolve())
    truth = _true_changes()
    assert [label for _, label in truth] == ["gravel", "grass"]
    changes = report["terrain_changes"]
    assert [c["label"] for c in changes] == ["gravel", "grass"]
    for change, (t_true, _) in zip(changes, truth, strict=True):
        assert abs(change["t"] - t_true) <= 2.0
    frames = _rows(SAMPLE / "frames.csv")
    written = _rows(out / "frames.csv")
    assert [r["file"] for r in written] == [r["file"] for r in frames]
    assert len(frames) == len(list((SAMPLE / "frames").iterdir()))
    assert report["frames"]["classified"] == len(frames)


def test_sample_is_small_and_regenerates_from_its_script(tmp_path, capsys):
    """Same script and seed: the same CSV and YAML files, the same frames up to JPEG coding.

    The frames are compared decoded and loosely: a different libjpeg build
    (another opencv-python wheel) may round the DCT differently by a grey level.
    """
    sizes = sum(p.stat().st_size for p in SAMPLE.rglob("*") if p.is_file())
    assert sizes < 5e6
    out = tmp_path / "chen2023"
    assert _module(REPO / "sample_images" / "make_sample.py").make(out) == 0
    for name in ("log.csv", "groundtruth.csv", "frames.csv", "config.yaml"):
        assert (out / name).read_bytes() == (SAMPLE / name).read_bytes(), name
    shipped = sorted(p.name for p in (SAMPLE / "frames").iterdir())
    assert sorted(p.name for p in (out / "frames").iterdir()) == shipped
    for name in shipped[::8]:
        a = cv2.imread(str(SAMPLE / "frames" / name)).astype(float)
        b = cv2.imread(str(out / "frames" / name)).astype(float)
        assert a.shape == b.shape and np.abs(a - b).mean() < 1.0, name


def test_default_classifier_is_small_loads_and_is_not_trained_on_the_sample():
    assert classifier_file.default_classifier_path() == MODEL.resolve()
    assert classifier_file.default_classifier() == MODEL.resolve()
    assert MODEL.stat().st_size < 2e6
    classifier = load_classifier(MODEL)
    assert {"grass", "gravel"} <= set(classifier.classes)
    make_default = _module(REPO / "models" / "make_default.py")
    make_sample = _module(REPO / "sample_images" / "make_sample.py")
    assert make_default.SEED != make_sample.SEED


def test_missing_default_classifier_is_a_one_line_error(tmp_path, capsys, monkeypatch):
    missing = tmp_path / "site-packages" / "models" / "default.npz"
    monkeypatch.setattr(classifier_file, "default_classifier_path", lambda: missing)
    images = _short_copy(tmp_path)
    out = tmp_path / "out"
    args = ["run", "--images", str(images), "--wheels", str(images / "log.csv")]
    assert main([*args, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and str(missing) in err and "pass --classifier" in err
    assert not out.exists()


def test_without_a_config_in_the_folder_the_built_in_defaults_are_used(tmp_path, capsys):
    images = _short_copy(tmp_path)
    out = tmp_path / "out"
    args = ["run", "--images", str(images), "--wheels", str(images / "log.csv")]
    assert main([*args, "--out", str(out)]) == 2  # the built-in camera is 640 x 480
    assert "camera configuration says 640x480" in capsys.readouterr().err
    failed = json.loads((out / "report.json").read_text())
    assert failed["status"] == "interrupted" and "640x480" in failed["reason"]
    assert main([*args, "--out", str(out), "--no-roi"]) == 2  # the failed run is kept
    assert "already holds an interrupted run" in capsys.readouterr().err
    assert main([*args, "--out", str(out), "--no-roi", "--overwrite"]) == 0
    printed = capsys.readouterr().out
    assert "found in the --images folder" not in printed and "model:" in printed
    report = json.loads((out / "report.json").read_text())
    assert report["inputs"]["config"] is None


@pytest.mark.parametrize("explicit", [False, True])
def test_an_explicit_config_and_model_win_over_the_defaults(tmp_path, capsys, explicit):
    images = _short_copy(tmp_path, config=True)
    other = tmp_path / "other.yaml"
    other.write_text((SAMPLE / "config.yaml").read_text(encoding="utf-8"), encoding="utf-8")
    model = tmp_path / "m.npz"
    shutil.copy(MODEL, model)
    out = tmp_path / "out"
    args = ["run", "--images", str(images), "--wheels", str(images / "log.csv")]
    args += ["--out", str(out)]
    if explicit:
        args += ["--config", str(other), "--classifier", str(model)]
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert ("found in the --images folder" in printed) != explicit and (
        "model:" in printed
    ) != explicit
    inputs = json.loads((out / "report.json").read_text())["inputs"]
    expected_config = other if explicit else images / "config.yaml"
    assert inputs["config"] == str(expected_config.resolve())
    assert inputs["model"] == str((model if explicit else MODEL).resolve())


def test_the_api_takes_the_same_defaults(tmp_path):
    images = _short_copy(tmp_path, config=True)
    options = workflows.RunOptions(images=images, progress=False)
    summary = workflows.run(images / "log.csv", tmp_path / "out", options)
    inputs = json.loads(summary.report_json.read_text())["inputs"]
    assert inputs["config"] == str((images / "config.yaml").resolve())
    assert inputs["model"] == str(MODEL.resolve())
    assert (summary.config.how, summary.config.path) == (IN_IMAGES, images / "config.yaml")
    assert (summary.classifier.how, summary.classifier.path) == (DEFAULT, MODEL)
