"""reporting.markdown: report.json rendered for people, from a real run of the demo log."""

from __future__ import annotations

import json

import pytest

from terrain_odom.app.run import run
from terrain_odom.config import load_config
from terrain_odom.reporting import run_markdown, table


@pytest.fixture(scope="module")
def report(examples_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    cfg = load_config(examples_dir / "demo.yaml")
    run(examples_dir / "demo_log.csv", out, config=cfg, progress=False)
    return json.loads((out / "report.json").read_text())


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
    counts = report["counts"]
    assert f"rows: {counts['rows']}, pose measurements fused: {counts['updates']}" in text
    changes = report["terrain_changes"]
    assert changes, "the demo log changes terrain"
    rows = [line for line in text.splitlines() if line.startswith("| ") and "applied" not in line]
    assert len(rows) == len(changes)
    for change, row in zip(changes, rows, strict=True):
        cells = [cell.strip() for cell in row.strip("|").split("|")]
        assert float(cells[0]) == pytest.approx(change["t"], abs=0.005)
        assert cells[2:4] == [change["previous"], change["label"]]
    assert "## Plots" not in text


def test_plots_and_priors_are_shown_when_present(report):
    with_priors = {**report, "inputs": {**report["inputs"], "priors": "/p/priors.yaml"}}
    text = run_markdown(with_priors, plots=["plots/trajectory.png"])
    assert "- offline priors: `/p/priors.yaml`" in text
    assert text.rstrip().endswith("![plots/trajectory.png](plots/trajectory.png)")


def test_no_change_is_said_in_words(report):
    text = run_markdown({**report, "terrain_changes": []})
    assert "No terrain change was confirmed." in text
