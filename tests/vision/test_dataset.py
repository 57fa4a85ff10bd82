"""Tests of feature extraction from labelled images (:mod:`terrain_odom.vision.dataset`)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import cv2
import numpy as np
import pytest
import skimage.data

from terrain_odom.config.classifier import ClassifierConfig, paper_config
from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.io.images import read_image_rgb, scan_image_folder
from terrain_odom.vision.dataset import extract_feature_sets, extract_features
from terrain_odom.vision.features import image_features


def write_rgb(path: Path, rgb: np.ndarray) -> None:
    """Write an RGB image with OpenCV (which expects BGR)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    assert cv2.imwrite(str(path), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))


def texture(name: str, index: int, size: int = 48) -> np.ndarray:
    """Return an RGB crop of a skimage texture, tinted per class."""
    grey = getattr(skimage.data, name)()
    crop = grey[index * size : (index + 1) * size, :size].astype(np.float64)
    tint = {"grass": (0.6, 1.0, 0.5), "gravel": (1.0, 0.9, 0.8), "brick": (1.0, 0.5, 0.4)}[name]
    return np.clip(crop[..., None] * np.array(tint), 0, 255).astype(np.uint8)


def make_folder(root: Path) -> Path:
    """3 grass (png), 2 gravel (upper-case JPG, one nested), 2 brick (tiff + bmp) and noise.

    All 48x48 (one tile with the default ``min_tile_size``) but ``grass/g1.png``, 96x96.
    """
    for i in range(3):
        write_rgb(root / "grass" / f"g{i}.png", texture("grass", i, 96 if i == 1 else 48))
    write_rgb(root / "gravel" / "a.JPG", texture("gravel", 0))
    write_rgb(root / "gravel" / "day2" / "b.jpeg", texture("gravel", 1))
    write_rgb(root / "brick" / "a.tiff", texture("brick", 0))
    write_rgb(root / "brick" / "b.BMP", texture("brick", 1))
    (root / "brick" / "notes.txt").write_text("not an image")
    write_rgb(root / "brick" / ".hidden.png", texture("brick", 2))
    write_rgb(root / ".cache" / "x.png", texture("brick", 2))
    return root


def test_features_are_flat_tiles_with_their_image_index(tmp_path):
    cfg = ClassifierConfig(min_tile_size=32)
    data = extract_features(
        scan_image_folder(make_folder(tmp_path)), cfg, read=read_image_rgb, jobs=1, progress=False
    )
    assert data.counts() == {"brick": 2, "grass": 3, "gravel": 2}
    assert data.paths[3].name == "g1.png"  # 96 px: 3x3 tiles, the others one tile
    assert np.bincount(data.region).tolist() == [1, 1, 1, 9, 1, 1, 1]
    assert data.features.shape == (15, 50) and data.region.shape == (15,)  # sfta+lbp+lab
    for i in (3, 4):
        expected = image_features(read_image_rgb(data.paths[i]), cfg)
        np.testing.assert_array_equal(data.features[data.region == i], expected)
    assert data.seconds.shape == (7,) and np.all(data.seconds > 0)
    assert data.skipped == ()


def test_select_keeps_all_tiles_of_the_chosen_images(tmp_path):
    data = extract_features(
        scan_image_folder(make_folder(tmp_path)),
        ClassifierConfig(min_tile_size=32),
        read=read_image_rgb,
        jobs=1,
        progress=False,
    )
    part = data.select([4, 3, 0])
    assert part.labels.tolist() == ["grass", "grass", "brick"]
    assert part.paths == (data.paths[4], data.paths[3], data.paths[0])
    np.testing.assert_array_equal(part.seconds, data.seconds[[4, 3, 0]])
    assert part.region.tolist() == [0] + [1] * 9 + [2]
    for new, old in enumerate((4, 3, 0)):
        np.testing.assert_array_equal(
            part.features[part.region == new], data.features[data.region == old]
        )
    assert part.config == data.config and part.classes == data.classes
    with pytest.raises(ValueError, match="distinct"):
        data.select([1, 1])


def test_unreadable_image_is_skipped_and_a_tiny_one_is_one_tile(tmp_path):
    root = make_folder(tmp_path)
    (root / "grass" / "broken.png").write_text("this is not a png")
    write_rgb(root / "gravel" / "tiny.png", texture("gravel", 2)[:2, :3])
    data = extract_features(
        scan_image_folder(root),
        ClassifierConfig(min_tile_size=32),
        read=read_image_rgb,
        jobs=1,
        progress=False,
    )
    assert [(s.path.name, s.reason) for s in data.skipped] == [
        ("broken.png", "cannot be read as an image")
    ]
    assert data.counts() == {"brick": 2, "grass": 3, "gravel": 3}
    tiny = data.paths.index(root / "gravel" / "tiny.png")
    assert np.count_nonzero(data.region == tiny) == 1
    assert np.all(np.isfinite(data.features))


def test_a_class_of_unreadable_images_is_an_error(tmp_path):
    root = make_folder(tmp_path / "d")
    for path in (root / "brick").iterdir():
        if path.is_file():
            path.write_text("garbage")
    with pytest.raises(InputFileError, match=r"no readable image in class\(es\) \['brick'\]"):
        extract_features(
            scan_image_folder(root),
            ClassifierConfig(min_tile_size=32),
            read=read_image_rgb,
            jobs=1,
            progress=False,
        )


def test_parallel_extraction_equals_serial_and_shares_equal_feature_settings(tmp_path):
    images = scan_image_folder(make_folder(tmp_path))
    paper = paper_config()
    knn_only_change = dataclasses.replace(paper, k=3)
    default = ClassifierConfig(min_tile_size=32)  # ragged: g1.png has 9 tiles
    serial = extract_feature_sets(
        images, [paper, knn_only_change, default], read=read_image_rgb, jobs=1, progress=False
    )
    parallel = extract_feature_sets(
        images, [paper, default], read=read_image_rgb, jobs=2, progress=False
    )
    for ours, theirs in ((parallel[0], serial[0]), (parallel[1], serial[2])):
        np.testing.assert_array_equal(ours.features, theirs.features)
        np.testing.assert_array_equal(ours.region, theirs.region)
        assert ours.paths == theirs.paths
    assert serial[2].features.shape[0] == 15
    assert serial[1].config == knn_only_change
    np.testing.assert_array_equal(serial[1].features, serial[0].features)
    with pytest.raises(ConfigError, match="jobs"):
        extract_features(images, paper, read=read_image_rgb, jobs=0)


def test_relative_paths_reach_reused_workers_whatever_their_working_directory(
    tmp_path, monkeypatch
):
    """Worker processes are reused: a relative path must not be resolved in their cwd."""
    first, second = tmp_path / "a", tmp_path / "b"
    make_folder(first / "set1")
    make_folder(second / "set2")
    paper = paper_config()
    counts = []
    for folder, name in ((first, "set1"), (second, "set2")):
        monkeypatch.chdir(folder)  # the workers started in the first folder serve the second
        images = scan_image_folder(Path(name))
        (features,) = extract_feature_sets(
            images, [paper], read=read_image_rgb, jobs=2, progress=False
        )
        counts.append(features.counts())
    assert counts[0] == counts[1] == {"brick": 2, "grass": 3, "gravel": 2}
