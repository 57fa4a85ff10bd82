"""Issue 24, round two: no command replaces a file it did not write; adopt; warnings.

compare, report accuracy, patches and calibrate through the manifest; ``adopt``
for folders from before manifests; library warnings as one line.
"""

from __future__ import annotations

import json
import os
import warnings
from pathlib import Path

import numpy as np
import pytest

from terrain_odom.cli.main import main
from terrain_odom.io.folder import MANIFEST, writing
from terrain_odom.io.images import MAX_IMAGE_BYTES, median_short_side
from tests.cli.conftest import Recorder
from tests.cli.refusal import refused


@pytest.fixture(scope="module")
def short_log(tmp_path_factory: pytest.TempPathFactory, examples_dir: Path) -> Path:
    """Return the demo log's first 30 s (grass)."""
    log = tmp_path_factory.mktemp("log") / "short.csv"
    lines = (examples_dir / "demo_log.csv").read_text().splitlines(keepends=True)
    log.write_text("".join(lines[:601]))
    return log


def _compare(log: Path, config: Path, out: Path) -> list[str]:
    argv = ["compare", "--wheels", str(log), "--eval", str(log), "--config", str(config)]
    return [*argv, "--models", "idd", "icr", "--maxiter", "5", "--out", str(out)]


def test_compare_replaces_its_own_files_never_fits_or_yours(
    short_log: Path, examples_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config, out = examples_dir / "demo.yaml", tmp_path / "cmp"
    assert main(_compare(short_log, config, out)) == 0
    first = (out / "compare.json").read_bytes()
    assert main(_compare(short_log, config, out)) == 0  # again: its own files replaced
    assert (out / "compare.json").read_bytes() != first  # a new report (its date and times)
    manifest = json.loads((out / MANIFEST).read_text())["files"]
    assert {e["command"] for e in manifest.values()} == {"compare"} and len(manifest) == 5
    (out / "compare.md").write_text("my notes\n")  # edited since
    err = refused(_compare(short_log, config, out), capsys, out)
    assert "compare.md: edited since terrain-odom compare wrote it" in err
    fits = tmp_path / "fits"
    fit = ["fit", "--model", "icr", "--wheels", str(short_log), "--config", str(config)]
    assert main([*fit, "--maxiter", "5", "--out", str(fits)]) == 0
    err = refused(_compare(short_log, config, fits), capsys, fits)
    assert "params_icr.yaml: written by terrain-odom fit, and compare would replace it" in err


@pytest.fixture(scope="module")
def classes(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Return two classes of 6 tiny PNG images (dark, light)."""
    import cv2

    root = tmp_path_factory.mktemp("classes")
    rng = np.random.default_rng(0)
    for label, mean in (("dark", 60), ("light", 180)):
        (root / label).mkdir()
        for i in range(6):
            image = rng.normal(mean, 20, (48, 48, 3)).clip(0, 255).astype(np.uint8)
            cv2.imwrite(str(root / label / f"{i}.png"), image)
    return root


def test_report_accuracy_refuses_a_file_it_did_not_write_before_computing(
    classes: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "acc"
    out.mkdir()
    (out / "accuracy.csv").write_text("my table\n")
    argv = ["report", "accuracy", "--images", str(classes), "--folds", "2", "--out", str(out)]
    err = refused(argv, capsys, out, classes)
    assert "accuracy.csv: not written by terrain-odom report accuracy in this folder" in err
    assert f"terrain-odom adopt {out} --by report" in err
    assert not (out / MANIFEST).exists()  # refused: the folder as it was


def test_calibrate_refuses_an_edited_config_of_degrade(
    examples_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out, config = tmp_path / "gps", str(examples_dir / "demo.yaml")
    degrade = ["degrade", "--wheels", str(examples_dir / "demo_log.csv"), "--config", config]
    assert main([*degrade, "--out", str(out), "--seed", "1"]) == 0
    with (out / "config.yaml").open("a") as handle:
        handle.write("# antenna measured by hand\n")
    argv = ["calibrate", "--wheels", str(out / "log.csv"), "--config", config, "--out", str(out)]
    err = refused(argv, capsys, out)
    assert "config.yaml: edited since terrain-odom degrade wrote it, and calibrate" in err


@pytest.fixture(scope="module")
def sim(recording: Recorder) -> Path:
    """Return a 12-s simulated recording with frames at 2 Hz."""
    folder = recording(12.0, seed=1, frame_rate=2.0, write=True, frames=True).folder
    assert folder is not None
    return folder


def _patches(sim: Path, out: Path, *extra: str) -> list[str]:
    argv = ["patches", "--images", str(sim), "--wheels", str(sim / "log.csv"), "--out", str(out)]
    return [*argv, "--horizon", "2s", *extra]


def test_patches_through_the_manifest_and_adopt_for_an_old_folder(
    sim: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "train"
    assert main(_patches(sim, out)) == 0
    (out / "grass" / "notes.txt").write_text("mine\n")
    (out / "grass" / "mine.png").write_bytes(b"my own picture")
    assert main(_patches(sim, out, "--overwrite")) == 0
    assert (out / "grass" / "notes.txt").read_text() == "mine\n"  # kept: not patches'
    assert (out / "grass" / "mine.png").read_bytes() == b"my own picture"
    listed = {p["file"] for p in json.loads((out / "patches.json").read_text())["patches"]}
    recorded = json.loads((out / MANIFEST).read_text())["files"]
    assert {n for n, e in recorded.items() if e["command"] == "patches"} == {
        "patches.json",
        *listed,
    }
    # a folder from before manifests: refused, with the way out; adopted, it appends
    (out / MANIFEST).unlink()
    err = refused(_patches(sim, out, "--append"), capsys, out)
    assert "patches.json: not written by terrain-odom patches in this folder" in err
    assert f"terrain-odom adopt {out} --by patches" in err
    capsys.readouterr()
    only = ["--only", "patches.json", *sorted(listed)]
    assert main(["adopt", str(out), "--by", "patches", *only]) == 0
    assert capsys.readouterr().out.startswith(
        f"{out}: {len(listed) + 1} files recorded as written by terrain-odom patches ("
    )
    assert main(_patches(sim, out, "--append")) == 0
    patches = json.loads((out / "patches.json").read_text())
    assert len(patches["recordings"]) == 2 and len(patches["patches"]) == 2 * len(listed)
    assert (out / "grass" / "notes.txt").read_text() == "mine\n"


def test_an_old_run_folder_is_adopted_explicitly_and_edits_after_stay_noticed(
    short_log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "old"
    run = ["run", "--wheels", str(short_log), "--out", str(out), "--no-plots"]
    assert main(run) == 0
    (out / MANIFEST).unlink()  # as a folder written by terrain-odom before 0.1's manifest
    err = refused([*run, "--overwrite"], capsys, out)
    hint = f"or if run wrote it before folders had a manifest: terrain-odom adopt {out} --by run"
    assert hint in err and err.count("terrain-odom adopt") == 1
    capsys.readouterr()
    assert main(["adopt", str(out), "--by", "run"]) == 0
    assert capsys.readouterr().out == (
        f"{out}: 5 files recorded as written by terrain-odom run (config.yaml, report.json, "
        "report.md, trajectory.csv, trajectory.tum)\n"
    )
    assert main(["adopt", str(out), "--by", "run"]) == 0  # again: nothing new
    assert capsys.readouterr().out.endswith("already recorded, left as they were: 5 files\n")
    with (out / "report.md").open("a") as handle:
        handle.write("my conclusion\n")
    err = refused([*run, "--overwrite"], capsys, out)
    assert "report.md: edited since terrain-odom run wrote it" in err
    (out / "report.md").unlink()
    assert main([*run, "--overwrite"]) == 0


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["--by", "run", "--only", "/etc/passwd"], "/etc/passwd: not within the folder"),
        (["--by", "run", "--only", "../x"], "no file within the folder"),
        (["--by", "run", "--only", MANIFEST], "the manifest itself"),
        (["--by", "run", "--only", "missing.csv"], "missing.csv: no file within the folder"),
    ],
)
def test_adopt_refuses_what_is_not_a_file_of_the_folder(
    argv: list[str], expected: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = tmp_path / "f"
    folder.mkdir()
    (folder / "a.csv").write_text("1\n")
    (folder / MANIFEST).write_text('{"format": 1, "files": {}}\n')
    err = refused(["adopt", str(folder), *argv], capsys, folder)
    assert expected in err


def test_adopt_needs_an_existing_folder_nobody_holds(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    err = refused(["adopt", str(tmp_path / "none"), "--by", "run"], capsys, tmp_path)
    assert "none: no such folder" in err and not (tmp_path / "none").exists()
    with writing(tmp_path, "run"):
        err = refused(["adopt", str(tmp_path), "--by", "fit"], capsys)
    assert f"in use by terrain-odom run (process {os.getpid()}" in err


def test_a_library_warning_is_one_line_at_the_end(
    examples_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch
) -> None:
    """A numpy warning met in a command: counted, said once at the end; after an error, not."""
    from terrain_odom.app import adopt as app_adopt

    real = app_adopt.adopt

    def warns(*args, **kwargs):
        np.float64(1.0) / np.float64(0.0)  # RuntimeWarning: divide by zero
        np.log(np.zeros(3))
        return real(*args, **kwargs)

    monkeypatch.setattr(app_adopt, "adopt", warns)
    capsys.readouterr()
    with warnings.catch_warnings():
        warnings.simplefilter("default")  # a user's Python: shown once per place, not raised
        assert main(["adopt", str(tmp_path), "--by", "run"]) == 0
        printed = capsys.readouterr()
        assert printed.out.startswith(f"{tmp_path}: 0 files recorded")
        assert printed.err.count("\n") == 1, printed.err
        assert printed.err.startswith(
            "terrain-odom: warning: RuntimeWarning: divide by zero encountered in scalar divide "
            "(test_hostile_round2_folders_cli.py:"
        )
        assert "and 1 other warning(s): the results above were computed past it" in printed.err
        assert main(["adopt", str(tmp_path / "none"), "--by", "run"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith("terrain-odom: error: ")


def test_image_sizes_are_read_from_regular_bounded_files_only(tmp_path: Path) -> None:
    """A FIFO (it would block) and an oversized file are left out of the median, not waited on."""
    import cv2

    small = tmp_path / "small.png"
    cv2.imwrite(str(small), np.zeros((30, 40, 3), np.uint8))
    fifo = tmp_path / "fifo.png"
    os.mkfifo(fifo)
    huge = tmp_path / "huge.png"
    huge.write_bytes(small.read_bytes())
    os.truncate(huge, MAX_IMAGE_BYTES + 1)  # sparse: a valid header, too large a file
    assert median_short_side([fifo, small, huge, tmp_path]) == 30.0
    assert median_short_side([fifo]) is None


def test_a_refused_command_leaves_no_folder_it_made(
    sim: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``patches`` locks its --out first; refused (a label no folder can have), removes it."""
    out = tmp_path / "new" / "train"
    err = refused(_patches(sim, out, "--label", "a/../b"), capsys, sim)
    assert "a/../b" in err and not out.exists()
