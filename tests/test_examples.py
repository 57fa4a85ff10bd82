"""The README quick start: the shipped demo log and config."""

from __future__ import annotations

import csv
import importlib.util
import json
from pathlib import Path

import numpy as np

from terrain_odom.cli.main import main

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = REPO / "examples"


def _generator():
    spec = importlib.util.spec_from_file_location("make_demo_log", EXAMPLES / "make_demo_log.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_demo_log_is_what_its_generator_writes():
    rows = _generator().make()
    with (EXAMPLES / "demo_log.csv").open(newline="") as handle:
        shipped = list(csv.DictReader(handle))
    assert shipped == rows


def test_quick_start_recovers_the_simulated_terrain_parameters(tmp_path, capsys):
    out = tmp_path / "out"
    log = str(EXAMPLES / "demo_log.csv")
    cfg = str(EXAMPLES / "demo.yaml")
    assert main(["run", "--wheels", log, "--out", str(out), "--config", cfg]) == 0
    assert "report:" in capsys.readouterr().out
    report = json.loads((out / "report.json").read_text())
    assert [(c["previous"], c["label"]) for c in report["terrain_changes"]] == [("grass", "gravel")]
    final = report["final_state"]
    truth = _generator().TERRAINS["gravel"]
    estimate = [final["y_l"], final["y_r"], final["x_icr"], final["alpha"]]
    np.testing.assert_allclose(estimate, truth, atol=0.02)
    assert main(["evaluate", "--run", str(out), "--log", log, "--config", cfg]) == 0
    models = json.loads((out / "evaluation.json").read_text())["models"]
    ekf = models["ekf (online)"]["translation_m_per_m"]["median"]
    idd = models["idd (B=0.5 m)"]["translation_m_per_m"]["median"]
    assert ekf < 0.1 * idd


def test_online_example_streams_the_demo_log_to_the_cli_result(tmp_path, capsys):
    out = tmp_path / "out"
    log, cfg = str(EXAMPLES / "demo_log.csv"), str(EXAMPLES / "demo.yaml")
    assert main(["run", "--wheels", log, "--out", str(out), "--config", cfg]) == 0
    with (out / "trajectory.csv").open(newline="") as handle:
        last = list(csv.DictReader(handle))[-1]
    spec = importlib.util.spec_from_file_location("online_example", EXAMPLES / "online.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    capsys.readouterr()
    state = module.main()
    assert "terrain: gravel" in capsys.readouterr().out
    assert state["terrain"] == last["terrain"] == "gravel"
    for name in ("t", "x", "y", "yaw", "y_l", "y_r", "x_icr", "alpha", "std_x", "std_alpha"):
        assert state[name] == float(last[name]), name
