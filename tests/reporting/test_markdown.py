"""reporting.markdown: a run's report rendered for people, from a real run of the demo log."""

from __future__ import annotations

import dataclasses
import json

import pytest

from terrain_odom.app.run import RunOptions, run
from terrain_odom.config import load_config
from terrain_odom.estimation.pose_measurement import PoseUse
from terrain_odom.reporting import run_markdown, table


@pytest.fixture(scope="module")
def report(examples_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    cfg = load_config(examples_dir / "demo.yaml")
    summary = run(examples_dir / "demo_log.csv", out, RunOptions(config=cfg, progress=False))
    assert json.loads(summary.report_json.read_text()) == json.loads(
        json.dumps(summary.report.to_dict())
    )  # the record is what report.json holds
    return summary.report


def test_table_formats_floats_and_missing_cells():
    text = table(["name", "value"], [["a", 1.23456], ["b", None], ["c", 7]], digits=2)
    assert text.splitlines() == [
        "| name | value |",
        "|---|---|",
        "| a | 1.23 |",
        "| b | - |",
        "| c | 7 |",
    ]


def test_run_report_lists_the_counts_and_every_confirmed_change(report):
    text = run_markdown(report)
    counts = report.counts
    assert f"rows: {counts.rows}, pose measurements fused: {counts.updates}" in text
    assert f"reset at: {report.config.terrain.reset_at}" in text
    changes = report.terrain_changes
    assert changes, "the demo log changes terrain"
    section = text.split("## Terrain changes", 1)[1].split("\n## ", 1)[0]
    rows = [
        line for line in section.splitlines() if line.startswith("| ") and "applied" not in line
    ]
    assert len(rows) == len(changes)
    for change, row in zip(changes, rows, strict=True):
        cells = [cell.strip() for cell in row.strip("|").split("|")]
        assert float(cells[0]) == pytest.approx(change.t, abs=0.005)
        assert cells[2:4] == [change.previous, change.label]
    assert "## Plots" not in text


def test_plots_and_priors_are_shown_when_present(report):
    with_priors = dataclasses.replace(
        report, inputs=dataclasses.replace(report.inputs, priors="/p/priors.yaml")
    )
    text = run_markdown(with_priors, plots=["plots/trajectory.png"])
    assert "- offline priors: `/p/priors.yaml`" in text
    assert text.rstrip().endswith("![plots/trajectory.png](plots/trajectory.png)")


def test_no_change_is_said_in_words(report):
    text = run_markdown(dataclasses.replace(report, terrain_changes=()))
    assert "No terrain change was confirmed." in text


def _rows(text: str, header: str) -> list[list[str]]:
    """Return the cells of the first table after ``header`` (the rows below its rule)."""
    lines = text.split(header, 1)[1].split("\n\n")
    table_lines = next(block for block in lines if block.startswith("| ")).splitlines()
    return [[c.strip() for c in line.strip("|").split("|")] for line in table_lines[2:]]


def test_pose_components_measured_used_and_dropped_by_reason(report):
    use = report.counts.pose_components
    text = run_markdown(report)
    rows = _rows(text, "## Pose measurements")
    assert rows == [
        ["position", str(use.position), str(use.used_position), "0"],
        ["heading", str(use.heading), str(use.used_heading), "0"],
    ]
    dropped = {"position: before a heading": 7, "heading: in a gap": 2, "position: x alone": 1}
    use = PoseUse(position=450, heading=20, used_position=442, used_heading=18, dropped=dropped)
    counts = dataclasses.replace(report.counts, pose_components=use)
    text = run_markdown(dataclasses.replace(report, counts=counts))
    assert _rows(text, "## Pose measurements") == [
        ["position", "450", "442", "8"],
        ["heading", "20", "18", "2"],
    ]
    assert _rows(text, "| component | measured") == [
        ["position", "before a heading", "7"],
        ["heading", "in a gap", "2"],
        ["position", "x alone", "1"],
    ]


def test_warnings_are_listed_or_said_to_be_none(report):
    assert "## Warnings\n\nNone." in run_markdown(dataclasses.replace(report, warnings=()))
    warnings = ("x_icr 0.52 m: an antenna ahead?", "second")
    text = run_markdown(dataclasses.replace(report, warnings=warnings))
    assert "## Warnings\n\n- x_icr 0.52 m: an antenna ahead?\n- second\n" in text
