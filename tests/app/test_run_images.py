"""``terrain-odom run --images``: the terrain-aware run on camera frames (simulated)."""

from __future__ import annotations

import csv
import dataclasses
import json
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from terrain_odom.app.frames import FRAME_COLUMNS
from terrain_odom.cli.main import main
from terrain_odom.config import load_config
from terrain_odom.estimation.odometry import run_icr_ekf
from terrain_odom.estimation.online import OnlineOdometry
from terrain_odom.io import classifier_file, read_wheel_log
from terrain_odom.records import Sighting

DURATION_S = 45
FRAME_RATE_HZ = 5


@pytest.fixture(scope="module")
def sim(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Simulate 45 s of chen2023 at 5 frames/s; train a model on its patches."""
    out = tmp_path_factory.mktemp("sim")
    args = ["simulate", "--out", str(out), "--seed", "0", "--duration", str(DURATION_S)]
    assert main([*args, "--frame-rate", str(FRAME_RATE_HZ)]) == 0
    assert main(["train", "--images", str(out / "patches"), "--out", str(out)]) == 0
    return out


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def _run(sim: Path, out: Path, *extra: str, images: Path | None = None, log: Path | None = None):
    args = ["run", "--wheels", str(log or sim / "log.csv"), "--out", str(out)]
    args += ["--images", str(images or sim), "--classifier", str(sim)]
    if "--config" not in extra:
        args += ["--config", str(sim / "config.yaml")]
    return main([*args, *extra])


def _short(sim: Path, tmp_path: Path, rows: list[tuple[str, str]], seconds: float = 3.0):
    """Make a frame folder with ``rows`` (t, file) and the log's first ``seconds``."""
    images = tmp_path / "images"
    (images / "frames").mkdir(parents=True)
    for name in sorted((sim / "frames").iterdir())[: int(seconds * FRAME_RATE_HZ) + 1]:
        shutil.copy(name, images / "frames" / name.name)
    with (images / "frames.csv").open("w", encoding="utf-8") as handle:
        handle.write("t,file\n" + "".join(f"{t},{f}\n" for t, f in rows))
    lines = (sim / "log.csv").read_text().splitlines()
    log = tmp_path / "log.csv"
    log.write_text("\n".join(lines[: int(seconds * 50) + 2]) + "\n")
    return images, log


def _true_changes(sim: Path) -> list[tuple[float, str]]:
    rows = _rows(sim / "groundtruth.csv")
    return [
        (float(b["t"]), b["terrain"])
        for a, b in zip(rows, rows[1:], strict=False)
        if a["terrain"] != b["terrain"]
    ]


def test_camera_run_confirms_the_true_changes_and_converges(sim, tmp_path, capsys):
    out = tmp_path / "out"
    assert _run(sim, out, "--groundtruth", str(sim / "groundtruth.csv")) == 0
    printed = capsys.readouterr().out
    assert str(out / "report.json") in printed and str(out / "report.md") in printed
    report = json.loads((out / "report.json").read_text())
    assert report["terrain_source"] == "camera"
    truth = _true_changes(sim)
    assert [label for _, label in truth] == ["gravel", "grass"]
    changes = report["terrain_changes"]
    assert [c["label"] for c in changes] == ["gravel", "grass"]
    for change, (t_true, _) in zip(changes, truth, strict=True):
        # reset on arrival at the ground seen ahead: close to the true change
        assert abs(change["t"] - t_true) <= 1.0, (change, t_true)
        assert change["t_confirmed"] < change["t"] - 0.3
    assert changes[1]["restored"] and all(c["reset"] for c in changes)
    gt = _rows(sim / "groundtruth.csv")[-1]
    final = report["final_state"]
    for name in ("y_l", "y_r", "x_icr"):
        assert abs(final[name] - float(gt[name])) < 0.05, (name, final[name], gt[name])
    frames = report["frames"]
    n_frames = DURATION_S * FRAME_RATE_HZ
    assert frames["total"] == n_frames and frames["classified"] == n_frames
    assert sum(frames["skipped"].values()) == 0 and report["frame_problems"] == []
    assert 0 < frames["ms_per_frame"]["mean"] <= frames["ms_per_frame"]["max"]
    assert report["inputs"]["images"] == str(sim.resolve())
    assert report["inputs"]["model"] == str((sim / "classifier.npz").resolve())
    rows = _rows(out / "frames.csv")
    assert list(rows[0]) == list(FRAME_COLUMNS) and len(rows) == n_frames
    assert rows[0]["file"] == "frames/000000.png"
    assert {r["roi_status"] for r in rows} <= {"inside", "clipped"}
    truth_at = {round(float(r["t"]), 2): r["terrain"] for r in _rows(sim / "groundtruth.csv")}
    correct = np.mean([truth_at[round(float(r["t"]) + 1.0, 2)] == r["label"] for r in rows[:-10]])
    assert correct > 0.9  # labels the ground one horizon (1 s) ahead
    assert all(float(r["ms_features_full"]) > 0 and float(r["ahead_m"]) > 0 for r in rows)
    assert all(float(r["ms_knn"]) > 0 and float(r["ms_knn_full"]) > 0 for r in rows)
    assert all(float(r["ms_features"]) + float(r["ms_knn"]) < float(r["ms_total"]) for r in rows)
    _check_groundtruth_report(report["groundtruth"], out)


def _check_groundtruth_report(section, out):
    """Check the scores of the seed-0 run (45 s, 5 frames/s) and the files showing them."""
    assert section["frames"]["accuracy"]["overall"]["accuracy"] > 0.9
    assert set(section["frames"]["accuracy"]["per_terrain"]) == {"grass", "gravel"}
    times = section["frames"]["feature_time"]["all"]
    assert times["roi"]["frames"] == times["full_frame"]["frames"] == DURATION_S * FRAME_RATE_HZ
    with_knn = section["frames"]["classification_time"]["all"]
    assert with_knn["roi"]["mean_ms"] > times["roi"]["mean_ms"]
    assert with_knn["full_frame"]["mean_ms"] > times["full_frame"]["mean_ms"]
    odometry = section["odometry"]
    assert list(odometry) == [
        "idd (B=0.5 m)",
        "ekf (no terrain)",
        "ekf (terrain)",
        "ekf (terrain + memory)",
    ]
    error = {name: m["mean_position_error_m"] for name, m in odometry.items()}
    assert (
        error["ekf (terrain + memory)"] < 0.8 * error["ekf (no terrain)"] < error["idd (B=0.5 m)"]
    )
    to_gravel, back_to_grass = section["reconvergence"]["ekf (terrain + memory)"]
    assert (to_gravel["to"], back_to_grass["to"]) == ("gravel", "grass")
    assert to_gravel["settling_s"] is not None and to_gravel["settling_s"] < 4.0
    assert back_to_grass["settling_s"] is not None and back_to_grass["settling_s"] < 0.5
    no_terrain = section["reconvergence"]["ekf (no terrain)"][0]["settling_s"]
    assert no_terrain is None or no_terrain > 2 * to_gravel["settling_s"]
    markdown = (out / "report.md").read_text()
    headings = ("Frame classification", "Feature extraction time", "Feature extraction + KNN")
    for heading in (*headings, "Model-odometry error"):
        assert f"## {heading}" in markdown
    for name in ("trajectory", "states", "frames", "mosaic"):
        image = cv2.imread(str(out / "plots" / f"{name}.png"))
        assert image is not None and min(image.shape[:2]) > 200
        assert f"(plots/{name}.png)" in markdown


def test_groundtruth_not_covering_the_log_is_a_clear_error(sim, tmp_path, capsys):
    rows = (sim / "groundtruth.csv").read_text().splitlines()
    short = tmp_path / "gt.csv"
    short.write_text("\n".join(rows[:100]) + "\n")
    assert _run(sim, tmp_path / "out", "--groundtruth", str(short)) == 2
    err = capsys.readouterr().err
    assert "gt.csv: covers 0-1.96 s but the wheel log" in err and "\n" not in err.strip()


def test_no_roi_classifies_whole_frames(sim, tmp_path):
    rows = [(f"{k / FRAME_RATE_HZ}", f"frames/{k:06d}.png") for k in range(5)]
    images, log = _short(sim, tmp_path, rows)
    assert _run(sim, tmp_path / "out", "--no-roi", images=images, log=log) == 0
    frames = _rows(tmp_path / "out" / "frames.csv")
    assert {r["roi_status"] for r in frames} == {"full_frame"}
    assert {(r["roi_x0"], r["roi_y0"], r["roi_x1"], r["roi_y1"]) for r in frames} == {
        ("0", "0", "320", "240")
    }
    assert {r["label"] for r in frames} == {"grass"}
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert report["frames"]["classification"] == "whole frame (--no-roi)"


def test_no_terrain_skips_classification(sim, tmp_path):
    out = tmp_path / "out"
    assert _run(sim, out, "--no-terrain") == 0
    assert not (out / "frames.csv").exists()
    report = json.loads((out / "report.json").read_text())
    assert report["terrain_source"] == "none" and report["terrain_changes"] == []
    assert report["frames"]["classification"].startswith("skipped")


def test_missing_and_unreadable_frames_are_reported_and_skipped(sim, tmp_path, capsys):
    rows = [(f"{k / FRAME_RATE_HZ}", f"frames/{k:06d}.png") for k in range(6)]
    rows[2] = ("0.4", "frames/gone.png")
    rows[4] = ("0.8", "frames/broken.png")
    images, log = _short(sim, tmp_path, rows)
    (images / "frames" / "broken.png").write_bytes(b"not a png")
    assert _run(sim, tmp_path / "out", images=images, log=log) == 0
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    problems = {p["file"]: p["problem"] for p in report["frame_problems"]}
    assert problems["frames/gone.png"] == "missing"
    assert problems["frames/broken.png"].startswith("unreadable")
    assert report["frames"]["classified"] == 4
    assert report["frames"]["skipped"]["missing_or_unreadable"] == 2
    assert len(_rows(tmp_path / "out" / "frames.csv")) == 4
    printed = capsys.readouterr().out
    assert "4 of 6 frames classified (skipped: 2 missing or unreadable)" in printed
    assert "  skipped frames/gone.png (missing)" in printed
    assert "  skipped frames/broken.png (unreadable" in printed


def test_frames_outside_the_log_are_skipped_with_a_count(sim, tmp_path, capsys):
    rows = [("-1.0", "frames/000000.png"), ("0.2", "frames/000001.png")]
    rows += [("0.4", "frames/000002.png"), ("99.0", "frames/000003.png")]
    rows += [("100.0", "frames/000004.png")]
    images, log = _short(sim, tmp_path, rows)
    assert _run(sim, tmp_path / "out", images=images, log=log) == 0
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    skipped = report["frames"]["skipped"]
    assert skipped["before_first_wheel_sample"] == 1
    assert skipped["after_last_wheel_sample"] == 2
    assert report["frames"]["classified"] == 2
    assert [r["t"] for r in _rows(tmp_path / "out" / "frames.csv")] == ["0.2", "0.4"]
    printed = capsys.readouterr().out
    assert "2 of 5 frames classified (skipped: 1 before the first wheel sample, 2 after" in printed


def test_frames_none_of_which_is_in_the_log_span_are_an_error(sim, tmp_path, capsys):
    rows = [(f"{1000.0 * k / FRAME_RATE_HZ}", f"frames/{k:06d}.png") for k in range(1, 4)]
    images, log = _short(sim, tmp_path, rows)  # milliseconds: 200, 400, 600 "s"
    assert _run(sim, tmp_path / "out", images=images, log=log) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "none of the 3 frames (t = 200-600 s)" in err
    assert "milliseconds" in err and not (tmp_path / "out" / "trajectory.csv").exists()


def test_model_with_other_feature_settings_stops_before_processing(sim, tmp_path, capsys):
    with np.load(sim / "classifier.npz") as data:
        arrays = {name: data[name] for name in data.files}
    meta = json.loads(str(arrays["metadata"]))
    meta["feature_version"] = 1
    arrays["metadata"] = np.array(json.dumps(meta))
    old = tmp_path / "old.npz"
    np.savez(old, **arrays)
    out = tmp_path / "out"
    args = ["run", "--wheels", str(sim / "log.csv"), "--out", str(out), "--images", str(sim)]
    assert main([*args, "--classifier", str(old)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "feature_version is 1" in err and "retrain" in err
    assert not out.exists()


def test_images_without_a_model_or_its_default_is_an_error(sim, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(
        classifier_file, "default_classifier_path", lambda: tmp_path / "no" / "default.npz"
    )
    args = ["run", "--wheels", str(sim / "log.csv"), "--out", str(tmp_path / "o")]
    assert main([*args, "--images", str(sim)]) == 2
    assert "--classifier" in capsys.readouterr().err


def test_region_outside_the_image_is_recorded_without_fallback(sim, tmp_path):
    config = tmp_path / "backwards.yaml"  # the camera looks behind the robot
    config.write_text(
        "camera: {width: 320, height: 240, fx: 200.0, fy: 200.0, cx: 159.5, cy: 119.5,\n"
        "  mount_x: -1.0, mount_height: 1.0, mount_pitch: 1.0, mount_yaw: 3.14159}\n"
    )
    rows = [(f"{k / FRAME_RATE_HZ}", f"frames/{k:06d}.png") for k in range(5)]
    images, log = _short(sim, tmp_path, rows)
    # no frame classified: an error naming why (issue 24), the frames' records kept
    assert _run(sim, tmp_path / "out", "--config", str(config), images=images, log=log) == 2
    frames = _rows(tmp_path / "out" / "frames.csv")
    assert len(frames) == 5
    for row in frames:
        assert row["roi_status"] == "outside"
        assert row["label"] == row["confidence"] == row["roi_x0"] == row["ms_features"] == ""
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert report["status"] == "interrupted"
    assert "none of the 5 frames in the log's span was classified" in report["reason"]
    assert "region of interest: 5 outside" in report["reason"]


def test_malformed_frames_csv_names_file_line_and_column(sim, tmp_path, capsys):
    images = tmp_path / "images"
    images.mkdir()
    (images / "frames.csv").write_text("t,file\n0.0,a.png\nsoon,b.png\n")
    assert _run(sim, tmp_path / "out", images=images) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "frames.csv, line 3, column 't'" in err


def test_image_size_differing_from_the_camera_is_an_error(sim, tmp_path, capsys):
    config = tmp_path / "big.yaml"
    config.write_text("camera: {width: 640, height: 480}\n")
    rows = [("0.0", "frames/000000.png")]
    images, log = _short(sim, tmp_path, rows)
    assert _run(sim, tmp_path / "out", "--config", str(config), images=images, log=log) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "320x240" in err and "640x480" in err


class _Recorder:
    """A frame observer that records the odometry's time (its latest row) when it is called."""

    def __init__(self, times):
        self.times = np.asarray(times, dtype=float)
        self.calls: list[tuple[float, float | None]] = []
        self.confirmed_labels: list[str] = []

    def feed(self, index: int, odometry: OnlineOdometry) -> None:
        t = float(self.times[index])
        self.calls.append((t, odometry.t))
        odometry.sighting(t, Sighting("grass" if t < 0.5 else "sand"))
        self.confirmed_labels.append(odometry.seen_terrain)


def test_frames_are_observed_after_the_rows_up_to_their_time(sim):
    full = read_wheel_log(sim / "log.csv")
    n = 30  # 0 .. 0.58 s at 50 Hz
    log = dataclasses.replace(full.take(slice(0, n)), terrain=None)
    frames = _Recorder([-0.1, 0.0, 0.03, 0.5, 0.51, 0.58, 0.7])
    result = run_icr_ekf(log, load_config(), frames=frames)
    assert result.frames_before == 1 and result.frames_after == 1
    for t_f, t_odometry in frames.calls:
        # observed right after row k, the last with t <= t_f, and before row k + 1
        assert t_odometry == log.t[np.count_nonzero(log.t <= t_f + 1e-12) - 1]
    assert [t for t, _ in frames.calls] == [0.0, 0.03, 0.5, 0.51, 0.58]
    assert frames.confirmed_labels == ["grass", "grass", "grass", "sand", "sand"]
    assert [c.label for c in result.changes] == ["sand"]  # confirm = 2
