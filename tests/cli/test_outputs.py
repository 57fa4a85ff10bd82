"""Outputs never destroy inputs: each command refuses an output path that is an input.

Through the command line: exit code 2, one line on stderr naming both paths,
no traceback, and every input byte-identical afterwards.
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pytest

from terrain_odom.cli.main import main

WARNING = "terrain-odom: warning: "


def _refused(argv: list[str], inputs: list[Path], capsys: pytest.CaptureFixture[str]) -> str:
    """Run ``argv``; check it is refused and leaves ``inputs`` as they were; return stderr."""
    before = {path: path.read_bytes() for path in inputs}
    listing = {path.parent: sorted(path.parent.iterdir()) for path in inputs}
    assert main(argv) == 2
    lines = capsys.readouterr().err.splitlines(keepends=True)
    err = "".join(line for line in lines if not line.startswith(WARNING))  # old spellings
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith("terrain-odom: error: ") and "refusing to overwrite the input" in err
    assert {path: path.read_bytes() for path in inputs} == before
    assert {folder: sorted(folder.iterdir()) for folder in listing} == listing
    return err


@pytest.fixture
def log(tmp_path: Path, examples_dir: Path) -> Path:
    """Return a copy of the demo wheel log in ``tmp_path/run``."""
    (tmp_path / "run").mkdir()
    return Path(shutil.copy(examples_dir / "demo_log.csv", tmp_path / "run" / "log.csv"))


def test_run_out_equal_to_the_images_folder(log: Path, capsys) -> None:
    images = log.parent
    frames = images / "frames.csv"
    frames.write_text("t,file\n0.0,0.png\n")
    cv2.imwrite(str(images / "0.png"), np.zeros((8, 8, 3), np.uint8))
    argv = ["run", "--wheels", str(log), "--images", str(images), "--out", str(images)]
    err = _refused(argv, [log, frames, images / "0.png"], capsys)
    assert str(frames) in err


def test_run_wheels_named_like_an_output(log: Path, capsys) -> None:
    wheels = log.rename(log.parent / "trajectory.csv")
    argv = ["run", "--wheels", str(wheels), "--out", str(wheels.parent)]
    assert str(wheels) in _refused(argv, [wheels], capsys)


@pytest.mark.parametrize(
    ("argv", "name"),
    [
        (lambda log: ["evaluate", "--wheels", str(log)], "evaluation.json"),
        (lambda log: ["fit", "--wheels", str(log), "--model", "idd"], "params_idd.yaml"),
        (lambda log: ["compare", "--wheels", str(log), "--eval", str(log)], "compare.json"),
    ],
    ids=["evaluate", "fit", "compare"],
)
def test_out_folder_holding_the_log(
    log: Path, argv: Callable[[Path], list[str]], name: str, capsys
) -> None:
    log = log.rename(log.parent / name)  # the file --out DIR would write
    _refused([*argv(log), "--out", str(log.parent)], [log], capsys)


@pytest.mark.parametrize(
    "argv",
    [
        lambda log: ["evaluate", "--wheels", str(log), "--out", str(log)],
        lambda log: ["fit", "--wheels", str(log), "--model", "idd", "--out", str(log)],
    ],
    ids=["evaluate", "fit"],
)
def test_out_file_equal_to_the_log(log: Path, argv: Callable[[Path], list[str]], capsys) -> None:
    # the old form, --out naming the file: the log renamed to the output's suffix
    log = log.rename(log.with_suffix(".json" if argv(log)[0] == "evaluate" else ".yaml"))
    _refused(argv(log), [log], capsys)


def test_evaluate_default_output_is_not_the_run(log: Path, capsys) -> None:
    log = log.rename(log.parent / "evaluation.json")
    _refused(["evaluate", "--wheels", str(log), "--run", str(log.parent)], [log], capsys)


def test_train_out_an_image(tmp_path: Path, capsys) -> None:
    images = tmp_path / "images"
    paths = []
    for name in ("grass", "gravel"):
        (images / name).mkdir(parents=True)
        paths.append(images / name / "0.png")
        cv2.imwrite(str(paths[-1]), np.zeros((8, 8, 3), np.uint8))
    config = tmp_path / "accuracy.json"
    config.write_text("{}\n")  # valid YAML: the defaults
    argv = ["report", "accuracy", "--images", str(images), "--config", str(config)]
    _refused([*argv, "--out", str(tmp_path)], [config, *paths], capsys)
    config = config.rename(tmp_path / "classifier.npz")  # the file train --out DIR writes
    argv = ["train", "--images", str(images), "--config", str(config)]
    _refused([*argv, "--out", str(tmp_path)], [config, *paths], capsys)
    _refused([*argv, "--out", str(config)], [config], capsys)  # the old form: a file


def test_simulate_over_its_config(tmp_path: Path, examples_dir: Path, capsys) -> None:
    config = Path(shutil.copy(examples_dir / "demo.yaml", tmp_path / "config.yaml"))
    argv = ["simulate", "--config", str(config), "--out", str(tmp_path), "--duration", "1"]
    _refused([*argv, "--no-frames", "--no-patches"], [config], capsys)


def test_write_errors_name_the_target(log: Path, capsys) -> None:
    for target in (log / "params.yaml", log / "fitted"):  # a file, a folder in a regular file
        argv = ["fit", "--wheels", str(log), "--model", "idd", "--maxiter", "1"]
        assert main([*argv, "--out", str(target)]) == 2
        lines = capsys.readouterr().err.splitlines(keepends=True)
        err = "".join(line for line in lines if not line.startswith(WARNING))
        assert err.count("\n") == 1 and str(target) in err and ".tmp" not in err


def _named(out: Path, printed: str, pattern: str = "**/*") -> None:
    """Check every file under ``out`` matching ``pattern`` is named in ``printed``.

    The folder's manifest (``.terrain-odom.json``, bookkeeping) is not an output.
    """
    files = [p for p in out.glob(pattern) if p.is_file() and p.name != ".terrain-odom.json"]
    assert files and [p for p in files if str(p) not in printed] == []


def test_every_file_written_is_named(tmp_path: Path, capsys) -> None:
    sim, run = tmp_path / "sim", tmp_path / "run"
    assert main(["simulate", "--out", str(sim), "--duration", "6", "--no-patches"]) == 0
    _named(sim, capsys.readouterr().out, "*")
    log, truth = str(sim / "log.csv"), str(sim / "groundtruth.csv")
    argv = ["--images", str(sim), "--groundtruth", truth, "--out", str(run)]
    assert main(["run", "--wheels", log, *argv]) == 0
    _named(run, capsys.readouterr().out)
    assert (
        main(["evaluate", "--wheels", log, "--run", str(run), "--config", str(sim / "config.yaml")])
        == 0
    )
    assert f"written:    {run / 'evaluation.json'}" in capsys.readouterr().out
    compared = tmp_path / "compare"
    fit = ["--models", "idd"]  # a 6-s run turns too little to fit any other model
    assert main(["compare", "--wheels", log, "--eval", log, *fit, "--out", str(compared)]) == 0
    _named(compared, capsys.readouterr().out)


def test_run_into_a_folder_holding_a_run(log: Path, tmp_path: Path, capsys) -> None:
    """A second ``run`` into a run's folder: exit 2, one line, the first run byte-identical."""
    out = tmp_path / "out"
    argv = ["run", "--wheels", str(log), "--out", str(out)]
    assert main(argv) == 0
    capsys.readouterr()
    files = sorted(p for p in out.rglob("*") if p.is_file())
    before = {path: path.read_bytes() for path in files}
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert "already holds a run" in err and "--overwrite" in err
    assert {
        path: path.read_bytes() for path in sorted(p for p in out.rglob("*") if p.is_file())
    } == before
    assert main([*argv, "--overwrite"]) == 0
    assert "trajectory:" in capsys.readouterr().out
