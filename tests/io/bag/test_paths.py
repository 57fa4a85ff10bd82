"""Whether a path names a bag, by its name only (``io.bag.paths``)."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.mark.parametrize(
    ("name", "expected"),
    [("run.bag", True), ("run.mcap", True), ("run_0.db3", True), ("run.csv", False),
     ("run.bag.csv", False), ("bag", False), ("run.BAG", False)],
)  # fmt: skip
def test_a_file_is_a_bag_by_its_suffix(tmp_path: Path, name: str, expected: bool) -> None:
    from terrain_odom.io.bag.paths import is_bag

    assert is_bag(tmp_path / name) is expected  # need not exist: by name only
    (tmp_path / name).write_text("not a bag at all")
    assert is_bag(str(tmp_path / name)) is expected


def test_a_folder_is_a_bag_when_it_holds_metadata_yaml(tmp_path: Path) -> None:
    from terrain_odom.io.bag.paths import is_bag

    folder = tmp_path / "rosbag2_run.bag"  # a folder: its suffix does not count
    folder.mkdir()
    assert not is_bag(folder)
    (folder / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    assert is_bag(folder)
