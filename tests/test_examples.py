"""The README quick start: the shipped demo log and config, and its commands as written."""

from __future__ import annotations

import csv
import importlib.util
import json
import re
import shlex
from pathlib import Path

import numpy as np

from terrain_odom.cli.main import main

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = REPO / "examples"
README = REPO / "README.md"


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
    assert main(["evaluate", "--run", str(out), "--wheels", log, "--config", cfg]) == 0
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


def _quick_start() -> str:
    """Return the README's "Quick start" section."""
    text = README.read_text(encoding="utf-8")
    return text.split("\n## Quick start\n", 1)[1].split("\n## ", 1)[0]


def _blocks(section: str, language: str) -> list[str]:
    """Return the fenced code blocks of ``section`` in ``language`` ("" for plain output)."""
    fences = re.findall(r"^```(\w*)\n(.*?)^```$", section, re.MULTILINE | re.DOTALL)
    return [body for lang, body in fences if lang == language]


def _shown(text: str) -> list[str]:
    """Return printed lines with what varies between machines and runs left out."""
    text = re.sub(r"\S*/(models/default\.npz|examples/demo_log\.csv)", r".../\1", text)
    text = re.sub(r"rows in \d+\.\d+ s", "rows in ... s", text)
    return [line.rstrip() for line in text.strip().splitlines()]


def test_readme_quick_start_runs_as_written_and_prints_what_it_shows(tmp_path, monkeypatch, capsys):
    for name in ("examples", "sample_images", "config"):
        (tmp_path / name).symlink_to(REPO / name)
    monkeypatch.chdir(tmp_path)
    section = _quick_start()
    # blocks on ../shared data (the real logs, the real bag) are run by their own tests
    blocks = [block for block in _blocks(section, "bash") if "../shared" not in block]
    commands = [shlex.split(line) for block in blocks for line in block.splitlines()]
    assert [words[:2] for words in commands] == [
        ["terrain-odom", "run"],
        ["terrain-odom", "run"],
        ["terrain-odom", "evaluate"],
        ["terrain-odom", "simulate"],
        ["terrain-odom", "patches"],
        ["terrain-odom", "train"],
        ["terrain-odom", "run"],
    ]
    printed = []
    for words in commands:
        assert main(words[1:]) == 0, shlex.join(words)
        printed.append(capsys.readouterr().out)
    camera_run, evaluation = _blocks(section, "")[:2]  # the later ones are on ../shared
    assert _shown(printed[0]) == _shown(camera_run)
    assert _shown(printed[2]) == _shown(evaluation)
    changes = json.loads((tmp_path / "out" / "report.json").read_text())["terrain_changes"]
    flat = " ".join(section.split())
    confirmed = " and ".join(f"{c['t_confirmed']} s" for c in changes)
    assert f"confirms the terrain changes at {confirmed}, looking ahead" in flat
    first, second = (f"{c['t']:.2f} s" for c in changes)
    assert f"on arrival, at {first} (true" in flat and f" and {second} (true" in flat
    final = json.loads((tmp_path / "out-demo" / "report.json").read_text())["final_state"]
    ends = ", ".join(f"{k}={final[k]:.3f}" for k in ("y_l", "y_r", "x_icr", "alpha"))
    assert f"The filter ends at `{ends}`" in section
