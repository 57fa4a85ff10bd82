"""``terrain-odom patches``: the chain patches -> train -> run on a simulated recording; errors."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from terrain_odom.cli.main import main
from tests.cli.conftest import Recorder


@pytest.fixture(scope="module")
def sim(recording: Recorder) -> Path:
    """Return a 26-s simulated recording (grass, then gravel) with frames at 2.5 Hz."""
    folder = recording(26.0, seed=2, frame_rate=2.5, write=True, frames=True).folder
    assert folder is not None
    return folder


def test_patches_train_run(sim: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The documented chain: the classifier trained on the patches labels the run's frames."""
    train = tmp_path / "train"
    argv = ["patches", "--images", str(sim), "--wheels", str(sim / "log.csv"), "--out", str(train)]
    capsys.readouterr()
    assert main([*argv, "--horizon", "2s"]) == 0
    out = capsys.readouterr().out.splitlines()
    counts = json.loads((train / "patches.json").read_text())["counts"]
    assert (
        out[0]
        == f"config:     {sim / 'config.yaml'} (found in the --images folder; --config to change)"
    )
    assert out[1].startswith(f"{sum(counts.values())} patches from 65 frames in ")
    assert out[1].endswith(
        f"grass {counts['grass']}, gravel {counts['gravel']} (labels: the log's terrain column, "
        "where the robot reaches the region)"
    )
    assert out[2].startswith("skipped:    ") and out[2].endswith("(roi_clipped)")
    assert out[-3:] == [
        f"patches:    {train / 'grass'}",
        f"            {train / 'gravel'}",
        f"report:     {train / 'patches.json'}",
    ]
    model = tmp_path / "model"
    assert main(["train", "--images", str(train), "--out", str(model), "--jobs", "1"]) == 0
    run = tmp_path / "run"
    argv = ["run", "--images", str(sim), "--wheels", str(sim / "log.csv"), "--out", str(run)]
    truth = ["--groundtruth", str(sim / "groundtruth.csv")]
    assert main([*argv, "--classifier", str(model), *truth]) == 0
    report = json.loads((run / "report.json").read_text())
    assert report["groundtruth"]["frames"]["accuracy"]["overall"]["accuracy"] >= 0.95
    assert [c["label"] for c in report["terrain_changes"]] == ["gravel"]


def _fails(capsys: pytest.CaptureFixture[str], argv: list[str], *fragments: str) -> None:
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    for fragment in fragments:
        assert fragment in err, err


def test_errors_are_one_line(sim: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    base = ["patches", "--images", str(sim), "--wheels", str(sim / "log.csv")]
    out = ["--out", str(tmp_path / "t")]
    _fails(capsys, [*base, *out, "--horizon", "2"], "--horizon: the region is predicted a duration")
    _fails(
        capsys, [*base, *out, "--label", "a b"], "--label: label 'a b' cannot name a class folder"
    )
    _fails(capsys, [*base, *out, "--labels", str(tmp_path / "none.csv")], "none.csv")
    assert main([*base, *out, "--label", "grass", "--horizon", "2s"]) == 0
    _fails(capsys, [*base, *out, "--label", "grass"], "holds patches already", "--overwrite")
    assert main([*base, *out, "--label", "grass", "--horizon", "2s", "--overwrite"]) == 0
    capsys.readouterr()
    assert main([*base, *out, "--label", "gravel", "--horizon", "2s", "--append"]) == 0
    lines = capsys.readouterr().out.splitlines()
    total = json.loads((tmp_path / "t" / "patches.json").read_text())["counts"]
    assert f"in --out:   grass {total['grass']}, gravel {total['gravel']}" in lines
    assert f"            {tmp_path / 't' / 'gravel'}" in lines
