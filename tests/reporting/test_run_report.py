"""reporting.run_report: the typed report of a run, its report.json, and report.md from it."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

from terrain_odom.app.inputs import GIVEN, Chosen
from terrain_odom.app.run import RunOptions, run
from terrain_odom.config import load_config
from terrain_odom.estimation.time_offset import PoseDelayEstimate, TimeCalibration
from terrain_odom.reporting import run_markdown
from terrain_odom.reporting.groundtruth import GroundTruthSection
from terrain_odom.reporting.outage import OutageSection
from terrain_odom.reporting.run_report import FrameCounts, FramesReport, RunInputs, RunOutputs

REPO = Path(__file__).resolve().parents[2]

TOP_KEYS = [
    "format_version", "terrain_odom_version", "command", "status", "estimator", "inputs",
    "terrain_source", "config", "time_calibration", "counts", "terrain_changes", "final_state",
    "final_std", "outputs", "run_time_s", "warnings", "outage_guard",
]  # fmt: skip


@pytest.fixture(scope="module")
def summary(examples_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    config = load_config(examples_dir / "demo.yaml")
    return run(examples_dir / "demo_log.csv", out, RunOptions(config=config, progress=False))


def test_report_json_is_the_records_dict_key_for_key_in_order(summary):
    written = json.loads(summary.report_json.read_text(encoding="utf-8"))
    assert list(written) == TOP_KEYS  # no frames, ground truth or calibration on this run
    assert written == json.loads(json.dumps(summary.report.to_dict()))
    assert list(written["counts"]) == [
        "rows", "pose_measurements", "updates", "segments", "terrain_changes", "pose_components",
    ]  # fmt: skip
    assert written["counts"]["rows"] == summary.report.counts.rows == 1800  # the demo log's rows
    assert written["terrain_changes"][0]["label"] == summary.report.terrain_changes[0].label


def test_report_md_is_rendered_from_the_record(summary):
    assert summary.report_md.read_text(encoding="utf-8") == run_markdown(
        summary.report, ["plots/trajectory.png", "plots/states.png"]
    )


def test_the_summary_names_the_folders_files(summary):
    folder = summary.out_dir
    assert summary.trajectory_csv == folder / "trajectory.csv"
    assert summary.config_yaml == folder / "config.yaml"
    assert summary.frames_csv is None and summary.recording is None
    assert summary.config == Chosen(None, GIVEN) and summary.classifier is None  # an object


@pytest.mark.parametrize(
    ("timing", "line"),
    [
        (TimeCalibration(0.0), None),
        (TimeCalibration(0.12), "- pose delay: 0.120 s (given)"),
        (TimeCalibration(0.1, position_std=0.004), "- pose delay: 0.100 s (estimated, +-0.004 s)"),
        (
            TimeCalibration(0.0, estimate=PoseDelayEstimate(0.0, 0.02, 1.0, 40)),
            "- pose delay: 0.000 s (estimated, +-0.020 s)",
        ),
    ],
)
def test_the_pose_delay_line_says_given_or_estimated(summary, timing, line):
    text = run_markdown(dataclasses.replace(summary.report, time_calibration=timing))
    shown = [row for row in text.splitlines() if row.startswith("- pose delay")]
    assert shown == ([] if line is None else [line])


def test_optional_sections_appear_only_when_set():
    inputs = RunInputs("/w.csv", None, None)
    assert inputs.to_dict() == {"wheels": "/w.csv", "config": None, "priors": None}
    camera = dataclasses.replace(inputs, with_images=True, images="/i", groundtruth="/g.csv")
    assert list(camera.to_dict()) == [
        "wheels",
        "config",
        "priors",
        "images",
        "model",
        "groundtruth",
    ]
    assert camera.to_dict()["model"] is None
    outputs = RunOutputs("trajectory.csv", "trajectory.tum", recording="run.rrd")
    assert list(outputs.to_dict()) == ["trajectory_csv", "trajectory_tum", "recording"]
    skipped = FramesReport("skipped (--no-terrain: frames not read)")
    assert skipped.to_dict() == {"classification": "skipped (--no-terrain: frames not read)"}
    counts = FrameCounts(10, 7, 1, 1, ("a.png (unreadable)",))
    frames = FramesReport("region of interest", counts, 2, {"too_small": 2, "inside": 7}, 1.5, 3.0)
    section = frames.to_dict()
    assert section["skipped"] == {
        "before_first_wheel_sample": 1,
        "after_last_wheel_sample": 1,
        "missing_or_unreadable": 1,
        "roi_outside_or_too_small": 2,
    }
    assert list(section["roi_status"]) == ["inside", "too_small"]  # sorted
    assert section["ms_per_frame"] == {"mean": 1.5, "max": 3.0}


GROUNDTRUTH_KEYS = ["settings", "true_changes", "odometry", "reconvergence", "resets", "frames"]


@pytest.fixture(scope="module")
def scored(tmp_path_factory):
    """Run the camera sample scored against its ground truth (``run --groundtruth``)."""
    sample = REPO / "sample_images" / "chen2023"
    out = tmp_path_factory.mktemp("scored")
    options = RunOptions(images=sample, groundtruth=sample / "groundtruth.csv", progress=False)
    return run(sample / "log.csv", out, options)


def test_the_groundtruth_section_is_the_records_dict_key_for_key_in_order(scored):
    written = json.loads(scored.report_json.read_text(encoding="utf-8"))["groundtruth"]
    section = scored.report.groundtruth
    assert isinstance(section, GroundTruthSection) and section.frames is not None
    assert written == json.loads(json.dumps(section.to_dict()))
    assert list(written) == GROUNDTRUTH_KEYS
    assert list(written["settings"]) == [
        "horizon_m",
        "icr_tolerance_m",
        "reset_at",
        "classification",
    ]
    assert list(written["frames"]) == ["truth", "accuracy", "feature_time", "classification_time"]
    name, odometry = next(iter(section.odometry.items()))
    assert list(written["odometry"][name]) == [
        "mean_position_error_m", "mean_heading_error_deg", "translation_m_per_m",
        "rotation_deg_per_m", "per_terrain_mean_position_error_m", "windows",
    ]  # fmt: skip
    assert written["odometry"][name]["windows"] == odometry.windows
    name, changes = next(iter(section.reconvergence.items()))
    assert [c["settling_s"] for c in written["reconvergence"][name]] == [
        c.settling_s for c in changes
    ]
    overall = written["frames"]["accuracy"]["overall"]
    assert list(overall) == ["frames", "correct", "accuracy"]
    assert overall["accuracy"] == section.frames.accuracy.overall.accuracy


def test_the_scored_report_md_is_rendered_from_the_record(scored):
    text = scored.report_md.read_text(encoding="utf-8")
    assert text == run_markdown(
        scored.report, [p.relative_to(scored.out_dir).as_posix() for p in scored.plots]
    )
    assert "## Frame classification" in text and "## ICR re-convergence" in text


def test_the_outage_guard_section_is_typed(summary):
    guard = summary.report.outage_guard
    assert isinstance(guard, OutageSection) and guard.skipped is None
    written = json.loads(summary.report_json.read_text(encoding="utf-8"))["outage_guard"]
    assert list(written) == ["every_s", "durations", "learned_worse_s"]
    assert written["learned_worse_s"] == list(guard.learned_worse_s or ())
    skipped = OutageSection(skipped="no positions")
    assert skipped.to_dict() == {"skipped": "no positions"}
    text = run_markdown(dataclasses.replace(summary.report, outage_guard=skipped))
    assert "Skipped: no positions." in text
