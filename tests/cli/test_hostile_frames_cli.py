"""Issue 24: frames that are no regular files, frames.csv pointing outside, class-folder links."""

from __future__ import annotations

import json
import os
from pathlib import Path

import cv2
import numpy as np
import pytest

from terrain_odom.cli.main import main
from terrain_odom.errors import InputFileError
from terrain_odom.io.images import read_image_bytes, scan_image_folder


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {
        p.relative_to(folder).as_posix(): p.read_bytes()
        for p in folder.rglob("*")
        if p.is_file() and not p.is_fifo()
    }


def _frames(folder: Path) -> Path:
    """Two colour camera frames at 1 s and 2 s of the demo log, of the default camera's size."""
    folder.mkdir()
    rng = np.random.default_rng(0)
    for t in ("1.0", "2.0"):
        frame = rng.integers(0, 255, (480, 640, 3), dtype=np.uint8)
        cv2.imwrite(str(folder / f"{t}.png"), frame)
    return folder


def test_a_fifo_among_the_frames_is_skipped_not_waited_for(
    examples_dir: Path, tmp_path: Path
) -> None:
    """A FIFO named like a frame: skipped as "not a regular file (a FIFO)", no hang."""
    images = _frames(tmp_path / "images")
    os.mkfifo(images / "1.5.png")
    (images / "frames.csv").write_text("t,file\n1.0,1.0.png\n1.5,1.5.png\n2.0,2.0.png\n")
    out = tmp_path / "run"
    argv = ["run", "--wheels", str(examples_dir / "demo_log.csv"), "--images", str(images)]
    assert main([*argv, "--out", str(out), "--no-checks", "--no-plots"]) == 0
    report = json.loads((out / "report.json").read_text())
    assert report["frame_problems"] == [
        {"t": 1.5, "file": "1.5.png", "problem": "not a regular file (a FIFO)"}
    ]


def test_image_files_are_read_only_when_regular_and_bounded(tmp_path: Path) -> None:
    assert read_image_bytes(tmp_path) == (None, "not a regular file (a folder)")
    assert read_image_bytes("/dev/zero") == (None, "not a regular file (a character device)")
    assert read_image_bytes(tmp_path / "none.png") == (None, "missing")
    big = tmp_path / "big.png"
    with big.open("wb") as handle:  # sparse: no disk used
        handle.truncate(300 * 2**20)
    assert read_image_bytes(big) == (None, "larger than 256 MiB")


@pytest.mark.parametrize("name", ["/etc/passwd", "../../../etc/passwd", "a/../../x.png"])
def test_frames_csv_entries_outside_the_folder_are_refused(
    name: str, examples_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    images = _frames(tmp_path / "images")
    (images / "frames.csv").write_text(f"t,file\n1.0,1.0.png\n2.0,{name}\n")
    before = _snapshot(tmp_path)
    argv = ["run", "--wheels", str(examples_dir / "demo_log.csv"), "--images", str(images)]
    assert main([*argv, "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert f"frames.csv, line 3, column 'file': {name!r} lies outside the frames' folder" in err
    assert _snapshot(tmp_path) == before


def test_a_class_folder_linking_to_the_images_root_is_refused(tmp_path: Path) -> None:
    """A class that is a link to the root (or to another class) would train images twice."""
    root = tmp_path / "classes"
    for name in ("grass", "gravel"):
        (root / name).mkdir(parents=True)
        cv2.imwrite(str(root / name / "a.png"), np.full((16, 16, 3), 90, np.uint8))
    (root / "all").symlink_to(root)
    with pytest.raises(InputFileError, match="all: class folder is .a link to.*holds the images"):
        scan_image_folder(root)
    (root / "all").unlink()
    (root / "grass2").symlink_to(root / "grass")
    with pytest.raises(InputFileError, match="lies within the class folder"):
        scan_image_folder(root)
    (root / "grass2").unlink()
    assert scan_image_folder(root).classes == ("grass", "gravel")


def test_a_camera_run_without_one_classified_frame_is_an_error_naming_why(
    examples_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``cx`` 100000: the region of interest lies outside every frame; one line, run interrupted."""
    images = _frames(tmp_path / "images")
    config = tmp_path / "camera.yaml"
    config.write_text("camera:\n  cx: 100000.0\n")
    out = tmp_path / "run"
    argv = ["run", "--wheels", str(examples_dir / "demo_log.csv"), "--images", str(images)]
    capsys.readouterr()
    assert main([*argv, "--config", str(config), "--out", str(out), "--no-checks"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "none of the 2 frames in the log's span was classified (region of interest: 2 " in err
    assert "check camera (mount_pitch, mount_height, fx, cx, cy) in --config" in err
    report = json.loads((out / "report.json").read_text())
    assert report["status"] == "interrupted" and "none of the 2 frames" in report["reason"]
    # the same frames with the whole image classified: fine
    assert main([*argv, "--config", str(config), "--out", str(tmp_path / "r2"), "--no-roi"]) == 0
