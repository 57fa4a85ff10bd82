"""``bench/small_patches.py`` builds the labelled patch folder it says (sizes, labels, counts)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from skimage import data

import bench.small_patches as bench
from terrain_odom.app.tune import load_grid
from terrain_odom.config.classifier import ClassifierConfig

BENCH = Path(__file__).resolve().parents[2] / "bench" / "small_patches.py"


def test_shipped_grid_files_are_valid_grids() -> None:
    config = BENCH.parents[1] / "config"
    for path in sorted(config.glob("grid_*.yaml")):
        assert load_grid(path, ClassifierConfig()), path  # raises ConfigError if invalid
    assert load_grid(config / "grid_small_patches.yaml", ClassifierConfig()) == [
        {
            "features": ["sfta+lab", "sfta+hsv"],
            "n_t": [2, 4],
            "min_tile_size": [16, 32],
            "k": [5, 9],
        }
    ]


def _files(folder: Path) -> dict[str, list[Path]]:
    return {d.name: sorted(d.glob("*.png")) for d in sorted(folder.iterdir())}


def test_skimage_patches_are_crops_of_their_class_image(tmp_path: Path) -> None:
    counts = bench.build_patches(tmp_path / "p", "skimage", crops=5, size=64)
    assert counts == {"grass": 5, "gravel": 5, "brick": 5}
    files = _files(tmp_path / "p")
    assert sorted(files) == ["brick", "grass", "gravel"]
    for label, paths in files.items():
        assert len(paths) == 5
        source = getattr(data, label)()
        for path in paths:
            patch = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
            assert patch.shape == (64, 64, 3) and patch.dtype == np.uint8
            assert np.array_equal(patch[..., 0], patch[..., 2])  # grey replicated
            # the patch is, pixel for pixel, somewhere in its own class's image
            match = cv2.matchTemplate(source, patch[..., 0], cv2.TM_SQDIFF)
            r, c = np.unravel_index(np.argmin(match), match.shape)
            assert np.array_equal(source[r : r + 64, c : c + 64], patch[..., 0])


def test_same_seed_same_patches_other_seed_others(tmp_path: Path) -> None:
    bench.build_patches(tmp_path / "a", "skimage", crops=3, size=32, seed=1)
    bench.build_patches(tmp_path / "b", "skimage", crops=3, size=32, seed=1)
    bench.build_patches(tmp_path / "c", "skimage", crops=3, size=32, seed=2)

    def pixels(name: str) -> list[bytes]:
        return [p.read_bytes() for paths in _files(tmp_path / name).values() for p in paths]

    assert pixels("a") == pixels("b")
    assert pixels("a") != pixels("c")


def test_refuses_a_folder_inside_the_repository() -> None:
    with pytest.raises(ValueError, match="inside the repository"):
        bench.build_patches(BENCH.parent / "patches_should_not_exist", "skimage", crops=1)
    assert not (BENCH.parent / "patches_should_not_exist").exists()


def test_random_crops_refuses_a_too_small_image() -> None:
    with pytest.raises(ValueError, match="smaller than"):
        bench.random_crops(np.zeros((40, 100)), 1, 64, np.random.default_rng(0))


def test_indoor_patches_come_from_distinct_photos_of_their_class(
    tmp_path: Path, indoor_dir: Path
) -> None:
    counts = bench.build_patches(tmp_path / "p", "indoor", photos=3, crops=2, indoor=indoor_dir)
    assert counts == {"carpet": 6, "tiles": 6, "wood": 6}
    for label, paths in _files(tmp_path / "p").items():
        stems = {p.stem.rsplit("_", 1)[0] for p in paths}
        assert len(stems) == 3  # 3 photos, 2 patches each
        assert all((indoor_dir / label / f"{stem}.jpg").is_file() for stem in stems)
        for path in paths:
            assert cv2.imread(str(path)).shape == (64, 64, 3)
