"""app.inputs: which configuration and classifier a command reads, and how each was chosen."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from terrain_odom.app.inputs import (
    DEFAULT,
    GIVEN,
    IMPORTED,
    IN_IMAGES,
    OF_RUN,
    Chosen,
    ConfigEdits,
    TerrainSource,
    check_frame_times,
    choose_classifier,
    choose_config,
    read_groundtruth_of,
    read_pose_logs,
    terrain_labels,
)
from terrain_odom.config import load_config
from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.io.frames import FrameList
from terrain_odom.records import WheelLog


def _config(path: Path, track_width: float) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f"robot: {{track_width: {track_width}}}\n", encoding="utf-8")
    return path


@pytest.fixture
def files(tmp_path: Path) -> dict[str, Path]:
    """One configuration per place a command may find one, each with its own track width."""
    return {
        "given": _config(tmp_path / "mine.yaml", 0.61),
        "run": _config(tmp_path / "run" / "config.yaml", 0.62),
        "imported": _config(tmp_path / "bag" / "config.yaml", 0.63),
        "images": _config(tmp_path / "images" / "config.yaml", 0.64),
    }


def test_the_configuration_is_chosen_in_order_and_says_how(files, tmp_path):
    places = {
        "imported": files["imported"], "images": tmp_path / "images", "run_dir": tmp_path / "run",
    }  # fmt: skip
    expected = [(GIVEN, 0.61), (OF_RUN, 0.62), (IMPORTED, 0.63), (IN_IMAGES, 0.64)]
    given: Path | None = files["given"]
    for how, width in expected:
        chosen = choose_config(None, given, **places)
        assert (chosen.file.how, chosen.config.robot.track_width) == (how, width)
        if how == GIVEN:
            given = None
        else:
            places.pop(next(k for k in ("run_dir", "imported", "images") if k in places))
    assert choose_config(None, None) == choose_config()
    nothing = choose_config(None, None, images=tmp_path / "empty")
    assert nothing.file.how == DEFAULT and nothing.path is None
    assert nothing.config == load_config(None)


def test_a_given_object_is_used_not_reloaded_and_edits_make_a_copy(files):
    config = load_config(files["images"])
    chosen = choose_config(config, files["given"])
    assert chosen.config is config  # not reloaded from its file
    assert chosen.file.how == GIVEN and chosen.path == files["given"]
    assert choose_config(config).file == Chosen(None, GIVEN)  # an object, no file
    edited = choose_config(config, edits=ConfigEdits(checks=False)).config
    assert edited.checks.enabled is False and config.checks.enabled is True


def test_edits_change_a_copy_of_the_files_values(files):
    edits = ConfigEdits(pose_delay="0.25", checks=False, reset_at="immediate", roi_horizon=2.5)
    chosen = choose_config(None, files["given"], edits=edits)
    config = chosen.config
    assert config.time.pose_delay == 0.25 and config.checks.enabled is False
    assert config.terrain.reset_at == "immediate" and config.roi.horizon == 2.5
    plain = load_config(files["given"])
    assert plain.checks.enabled is True and plain.terrain.reset_at == "arrival"
    assert dataclasses.replace(config, time=plain.time, checks=plain.checks, terrain=plain.terrain,
                               roi=plain.roi) == plain  # fmt: skip


def test_a_bad_configuration_file_is_named(tmp_path):
    bad = tmp_path / "images" / "config.yaml"
    bad.parent.mkdir()
    bad.write_text("robot: {track_width: -1}\n", encoding="utf-8")
    with pytest.raises(ConfigError, match="track_width"):
        choose_config(images=tmp_path / "images")


def test_the_classifier_is_the_given_file_or_the_packaged_one(tmp_path):
    assert choose_classifier(tmp_path / "m.npz").how == GIVEN
    default = choose_classifier(None)
    assert default.how == DEFAULT and default.path is not None and default.path.is_file()
    assert default.path.name == "default.npz"


def _log(t: np.ndarray, terrain: np.ndarray | None = None) -> WheelLog:
    n = t.size
    pose = np.full((n, 3), np.nan)
    pose[::2] = 0.0
    return WheelLog(t, np.ones(n), np.ones(n), pose, terrain, np.zeros(n, dtype=int), "log.csv")


def test_terrain_labels_follow_the_source():
    labels = np.array(["grass"] * 4)
    log = _log(np.arange(4.0), labels)
    assert terrain_labels(log, TerrainSource.AUTO) is labels  # the log's array, no copy
    assert terrain_labels(log, TerrainSource.NONE) is None
    bare = _log(np.arange(4.0))
    assert terrain_labels(bare, TerrainSource.AUTO) is None
    with pytest.raises(InputFileError, match="needs a 'terrain' column"):
        terrain_labels(bare, TerrainSource.LOG)


def test_frames_outside_the_logs_span_are_refused():
    log = _log(np.arange(10.0))
    check_frame_times(
        FrameList(np.array([8.5, 20.0]), [Path("a.png"), Path("b.png")], "i"), log, "i"
    )
    frames = FrameList(np.array([9500.0, 9600.0]), [Path("a.png"), Path("b.png")], "i")
    with pytest.raises(InputFileError, match="milliseconds"):
        check_frame_times(frames, log, "i")


def test_ground_truth_must_cover_the_log(tmp_path):
    path = tmp_path / "gt.csv"
    rows = "".join(f"{t},0,0,0,0.3,-0.3,0,grass\n" for t in range(5))
    path.write_text("t,x,y,yaw,y_l,y_r,x_icr,terrain\n" + rows, encoding="utf-8")
    assert read_groundtruth_of(path, _log(np.arange(4.0))).t.size == 5
    with pytest.raises(InputFileError, match="covers 0-4 s but the wheel log"):
        read_groundtruth_of(path, _log(np.arange(8.0)))


def test_logs_for_a_fit_need_poses_and_are_each_calibrated():
    timing: dict = {}
    config = load_config(None)
    logs = read_pose_logs([_log(np.arange(0.0, 5.0, 0.1))], config, "training", timing)
    assert len(logs) == 1 and list(timing) == ["log.csv"]
    no_pose = dataclasses.replace(_log(np.arange(4.0)), pose=np.full((4, 3), np.nan))
    with pytest.raises(InputFileError, match="no pose measurements .* a training log needs"):
        read_pose_logs([no_pose], config, "training", {})
    with pytest.raises(InputFileError, match="no evaluation log given"):
        read_pose_logs([], config, "evaluation", {})
