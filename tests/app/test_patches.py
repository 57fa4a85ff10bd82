"""Training patches from a recording: labels against the simulator's truth, intervals, outputs."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from terrain_odom.app.patches import (
    PATCHES_JSON,
    LabelIntervals,
    PatchesResult,
    make_patches,
    read_intervals,
)
from terrain_odom.app.simulate import write_simulation
from terrain_odom.config import Config, load_config
from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.io.images import read_image_rgb
from terrain_odom.sim import Simulation, get_scenario, simulate
from terrain_odom.vision.camera import GroundCamera


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> tuple[Simulation, Path]:
    """Return a 32-s chen2023 run (grass, then gravel from ~19 s) with frames at 5 Hz."""
    scenario = dataclasses.replace(get_scenario("chen2023"), duration=32.0, frame_rate=5.0)
    sim = simulate(scenario, seed=1)
    out = tmp_path_factory.mktemp("recording")
    write_simulation(sim, out, frames=True, patches=False)
    return sim, out


def _config(folder: Path, horizon: float = 2.0) -> Config:
    """Return the recording's configuration, the region predicted ``horizon`` s ahead."""
    cfg = load_config(folder / "config.yaml")
    return dataclasses.replace(cfg, roi=dataclasses.replace(cfg.roi, horizon=horizon))


@pytest.fixture(scope="module")
def by_log(
    recording: tuple[Simulation, Path], tmp_path_factory: pytest.TempPathFactory
) -> PatchesResult:
    """Return the patches of the recording labelled by its terrain column, 2 s ahead."""
    _, folder = recording
    out = tmp_path_factory.mktemp("by_log") / "train"
    return make_patches(folder, folder / "log.csv", out, config=_config(folder))


def _true_terrain(sim: Simulation, entry: dict, camera: GroundCamera) -> tuple[str, str]:
    """Majority true terrain of the ground a patch shows, and the terrain under the robot then."""
    k = int(np.searchsorted(sim.motion.t, entry["t"] + 1e-9)) - 1
    x0, y0, x1, y1 = entry["box"]
    u, v = np.meshgrid(np.arange(x0, x1, 3), np.arange(y0, y1, 3))
    ground = camera.backproject(np.c_[u.ravel(), v.ravel()])
    x, y, yaw = sim.motion.pose[k]
    c, s = np.cos(yaw), np.sin(yaw)
    world = ground @ np.array([[c, s], [-s, c]]) + [x, y]
    names, counts = np.unique(sim.ground.terrain_at(world), return_counts=True)
    return str(names[np.argmax(counts)]), str(sim.motion.terrain[k])


def test_labels_match_the_simulated_ground(
    recording: tuple[Simulation, Path], by_log: PatchesResult
) -> None:
    """Every patch is filed under the true terrain of the ground it shows (simulator's map).

    Labelling at the frame's time instead would be wrong for the frames that
    look at gravel while the robot is still on grass.
    """
    sim, folder = recording
    result = by_log
    report = json.loads(result.patches_json.read_text())
    camera = GroundCamera(_config(folder).camera)
    truth = [_true_terrain(sim, e, camera) for e in report["patches"]]
    labels = [e["label"] for e in report["patches"]]
    assert result.counts["grass"] > 15 and result.counts["gravel"] > 30  # 23 and 53
    assert labels == [seen for seen, _ in truth]
    at_frame_time = sum(seen != under for seen, under in truth)
    assert at_frame_time >= 2  # the rule matters: these frames see gravel from the grass
    assert set(result.skipped) == {"roi_clipped", "not_reached"}  # 75 and 9
    assert result.skipped["not_reached"] < 15  # the last 2 s (10 frames) at most
    assert sum(result.counts.values()) + sum(result.skipped.values()) == result.frames == 160


def test_patch_files_are_the_region_of_the_frame(by_log: PatchesResult) -> None:
    """A patch is its frame's box, pixel for pixel, at LABEL/<frame stem>.png."""
    entry = json.loads(by_log.patches_json.read_text())["patches"][5]
    patch = read_image_rgb(by_log.out_dir / entry["file"])
    frame = read_image_rgb(entry["frame"])
    assert patch is not None and frame is not None
    x0, y0, x1, y1 = entry["box"]
    assert entry["file"] == f"{entry['label']}/{Path(entry['frame']).stem}.png"
    np.testing.assert_array_equal(patch, frame[y0:y1, x0:x1])
    assert entry["t_label"] > entry["t"]  # labelled where the robot reaches the region


def test_intervals_give_the_log_column_labels(
    recording: tuple[Simulation, Path], by_log: PatchesResult, tmp_path: Path
) -> None:
    """Intervals made from the true terrain changes label the patches as the terrain column."""
    sim, folder = recording
    change = float(sim.motion.t[np.argmax(sim.motion.terrain != sim.motion.terrain[0])])
    spans = tmp_path / "spans.csv"
    spans.write_text(f"t_start,t_end,label\n{change},100,gravel\n-1,{change},grass\n")
    by_spans = make_patches(
        folder, folder / "log.csv", tmp_path / "b", config=_config(folder), intervals=spans
    )
    assert by_spans.label_source == "intervals" and by_log.label_source == "log"
    assert by_spans.counts == by_log.counts
    assert sorted(p.name for p in (tmp_path / "b" / "gravel").iterdir()) == sorted(
        p.name for p in (by_log.out_dir / "gravel").iterdir()
    )


def test_one_label_keeps_the_frames_near_the_end(
    recording: tuple[Simulation, Path], tmp_path: Path
) -> None:
    """One label for the recording: no frame is skipped for a region not reached."""
    _, folder = recording
    result = make_patches(
        folder, folder / "log.csv", tmp_path / "t", config=_config(folder), label="field"
    )
    assert set(result.counts) == {"field"} and set(result.skipped) == {"roi_clipped"}
    assert result.counts["field"] + result.skipped["roi_clipped"] == result.frames


def test_region_of_run_at_its_horizon_is_clipped_here(
    recording: tuple[Simulation, Path], tmp_path: Path
) -> None:
    """At run's 1-s horizon the simulated camera cuts off the footprint's rear: all skipped."""
    _, folder = recording
    result = make_patches(folder, folder / "log.csv", tmp_path / "t", label="x")
    assert result.counts == {} and result.skipped == {"roi_clipped": 160}


def test_refuses_a_folder_with_patches_unless_overwrite(
    recording: tuple[Simulation, Path], tmp_path: Path
) -> None:
    _, folder = recording
    cfg, out = _config(folder), tmp_path / "t"
    make_patches(folder, folder / "log.csv", out, config=cfg, label="old")
    with pytest.raises(InputFileError, match="holds patches already"):
        make_patches(folder, folder / "log.csv", out, config=cfg, label="new")
    (out / "old" / "mine.png").write_bytes(b"not listed")
    make_patches(folder, folder / "log.csv", out, config=cfg, label="new", overwrite=True)
    assert [p.name for p in (out / "old").iterdir()] == ["mine.png"]  # only listed ones removed
    assert set(json.loads((out / PATCHES_JSON).read_text())["counts"]) == {"new"}
    with pytest.raises(ConfigError, match="exclude each other"):
        make_patches(folder, folder / "log.csv", out, label="x", overwrite=True, append=True)


def test_append_adds_a_recording(recording: tuple[Simulation, Path], tmp_path: Path) -> None:
    """One recording per terrain into one folder; a name taken gets -2."""
    _, folder = recording
    cfg, out = _config(folder), tmp_path / "t"
    first = make_patches(folder, folder / "log.csv", out, config=cfg, label="grass")
    second = make_patches(folder, folder / "log.csv", out, config=cfg, label="gravel", append=True)
    third = make_patches(folder, folder / "log.csv", out, config=cfg, label="grass", append=True)
    n = first.counts["grass"]
    assert second.counts == {"gravel": n} and third.counts == {"grass": n}
    assert third.total == {"grass": 2 * n, "gravel": n}
    report = json.loads((out / PATCHES_JSON).read_text())
    assert report["counts"] == third.total and len(report["recordings"]) == 3
    assert [r["inputs"]["label"] for r in report["recordings"]] == ["grass", "gravel", "grass"]
    files = [e["file"] for e in report["patches"] if e["recording"] == 2]
    assert all(f.endswith("-2.png") for f in files)
    assert len(list((out / "grass").iterdir())) == 2 * n


def test_never_writes_over_a_file_it_did_not_write(tmp_path: Path) -> None:
    """Patches into the frame folder, under a label that is its frames' sub-folder: renamed."""
    sim = simulate(dataclasses.replace(get_scenario("chen2023"), duration=6.0, frame_rate=1.0))
    write_simulation(sim, tmp_path, frames=True, patches=False)
    before = {p.name: p.read_bytes() for p in (tmp_path / "frames").iterdir()}
    result = make_patches(
        tmp_path, tmp_path / "log.csv", tmp_path, config=_config(tmp_path), label="frames"
    )
    files = [e["file"] for e in json.loads(result.patches_json.read_text())["patches"]]
    assert files and all(f.startswith("frames/") and f.endswith("-2.png") for f in files)
    assert {n: (tmp_path / "frames" / n).read_bytes() for n in before} == before


def test_a_frame_of_another_size_is_one_error(
    recording: tuple[Simulation, Path], tmp_path: Path
) -> None:
    _, folder = recording
    cfg = _config(folder)
    cfg = dataclasses.replace(cfg, camera=dataclasses.replace(cfg.camera, width=640))
    with pytest.raises(InputFileError, match="320x240 px but the camera's is 640x240"):
        make_patches(folder, folder / "log.csv", tmp_path / "t", config=cfg, label="x")
    assert not (tmp_path / "t" / "x").exists()


def test_labels_must_name_folders(recording: tuple[Simulation, Path], tmp_path: Path) -> None:
    _, folder = recording
    with pytest.raises(ConfigError, match="cannot name a class folder"):
        make_patches(folder, folder / "log.csv", tmp_path / "t", label="../up")
    with pytest.raises(ConfigError, match="exclude each other"):
        make_patches(folder, folder / "log.csv", tmp_path / "t", label="a", intervals=__file__)


def test_a_log_without_terrain_needs_a_label(
    recording: tuple[Simulation, Path], tmp_path: Path
) -> None:
    _, folder = recording
    log = tmp_path / "log.csv"
    lines = (folder / "log.csv").read_text().splitlines()
    log.write_text("\n".join(line.rsplit(",", 1)[0] for line in lines) + "\n")
    with pytest.raises(InputFileError, match="no 'terrain' column.*--label"):
        make_patches(folder, log, tmp_path / "t")


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("t_start,t_end\n0,1\n", "missing column 'label'"),
        ("t_start,t_end,label\n", "no interval"),
        ("t_start,t_end,label\n0,x,grass\n", "line 2, column 't_end'.*not a finite time"),
        ("t_start,t_end,label\n2,1,grass\n", "line 2: t_end 1 is not after t_start 2"),
        ("t_start,t_end,label\n0,5,a\n4,9,b\n", "line 3: overlaps the interval on line 2"),
        ("t_start,t_end,label\n0,5,a/b\n", "line 2, column 'label'.*cannot name"),
    ],
)
def test_malformed_intervals(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "spans.csv"
    path.write_text(text)
    with pytest.raises(InputFileError, match=message):
        read_intervals(path)


def test_intervals_are_sorted_and_half_open(tmp_path: Path) -> None:
    path = tmp_path / "spans.csv"
    path.write_text("t_start,t_end,label\n10,20,gravel\n0,10,grass\n25,30,brick\n")
    spans = read_intervals(path)
    assert isinstance(spans, LabelIntervals)
    assert spans.labels == ("grass", "gravel", "brick")
    got = [spans.at(t) for t in (-1.0, 0.0, 9.999, 10.0, 20.0, 22.0, 29.0, 30.0)]
    assert got == ["", "grass", "grass", "gravel", "", "", "brick", ""]
