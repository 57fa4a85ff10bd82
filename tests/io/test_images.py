"""Tests of labelled image folders and image decoding (:mod:`terrain_odom.io.images`)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from terrain_odom.errors import InputFileError
from terrain_odom.io.frames import IMAGE_SUFFIXES as FRAME_SUFFIXES
from terrain_odom.io.images import IMAGE_SUFFIXES, read_image_rgb, scan_image_folder


def write_grey(path: Path, value: int) -> None:
    """Write a small uniform image (the format from the suffix)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    assert cv2.imwrite(str(path), np.full((6, 8), value, dtype=np.uint8))


def test_scan_lists_images_per_class_at_any_depth_in_any_case(tmp_path):
    for name in ("grass/g0.png", "grass/g1.png", "grass/g2.png", "gravel/a.JPG"):
        write_grey(tmp_path / name, 10)
    for name in ("gravel/day2/b.jpeg", "brick/a.tiff", "brick/b.BMP"):
        write_grey(tmp_path / name, 20)
    (tmp_path / "brick" / "notes.txt").write_text("not an image")
    write_grey(tmp_path / "brick" / ".hidden.png", 30)
    write_grey(tmp_path / ".cache" / "x.png", 30)
    images = scan_image_folder(tmp_path)
    assert images.root == tmp_path
    assert images.classes == ("brick", "grass", "gravel")
    assert images.counts() == {"brick": 2, "grass": 3, "gravel": 2}
    assert len(images.paths) == len(images.labels) == 7
    assert images.paths[0].name == "a.tiff" and images.labels[0] == "brick"
    assert images.paths[-1] == tmp_path / "gravel" / "day2" / "b.jpeg"


def test_empty_class_single_class_and_missing_folder_are_errors(tmp_path):
    write_grey(tmp_path / "d" / "grass" / "a.png", 10)
    write_grey(tmp_path / "d" / "gravel" / "a.png", 20)
    (tmp_path / "d" / "asphalt").mkdir()
    (tmp_path / "d" / "asphalt" / "readme.md").write_text("to do")
    with pytest.raises(InputFileError, match="class 'asphalt' has no images"):
        scan_image_folder(tmp_path / "d")
    write_grey(tmp_path / "single" / "grass" / "a.png", 10)
    with pytest.raises(InputFileError, match=r"at least 2 classes, found \['grass'\]"):
        scan_image_folder(tmp_path / "single")
    with pytest.raises(InputFileError, match="image folder not found"):
        scan_image_folder(tmp_path / "nowhere")


def test_read_image_converts_bgr_to_rgb(tmp_path):
    rgb = np.zeros((4, 5, 3), dtype=np.uint8)
    rgb[..., 0] = 200  # red
    assert cv2.imwrite(str(tmp_path / "red.png"), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    np.testing.assert_array_equal(read_image_rgb(tmp_path / "red.png"), rgb)
    write_grey(tmp_path / "grey.png", 77)
    grey = read_image_rgb(tmp_path / "grey.png")
    assert grey.shape == (6, 8, 3) and grey.dtype == np.uint8 and np.all(grey == 77)
    (tmp_path / "bad.png").write_bytes(b"\x89PNG but not really")
    assert read_image_rgb(tmp_path / "bad.png") is None
    (tmp_path / "empty.jpg").write_bytes(b"")
    assert read_image_rgb(tmp_path / "empty.jpg") is None
    assert read_image_rgb(tmp_path / "missing.png") is None


def test_image_suffixes_have_one_home():
    assert FRAME_SUFFIXES is IMAGE_SUFFIXES
    assert {".png", ".jpg", ".tiff"} <= IMAGE_SUFFIXES
