"""reporting.recording: a run written as a Rerun recording, read back with the SDK's RRD reader."""

from __future__ import annotations

import io
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest
from rerun.chunk import RrdReader

from terrain_odom.estimation.odometry import OdometryResult
from terrain_odom.records import TerrainChange, WheelLog
from terrain_odom.reporting.figure import terrain_colours
from terrain_odom.reporting.recording import TIMELINE, RecordedFrame, record_run

NAMES = ("x", "y", "yaw", "y_l", "y_r", "x_icr")
JPEG = (
    Path(__file__).resolve().parents[2] / "sample_images/chen2023/frames/000000.jpg"
).read_bytes()


def read_rrd(path: Path) -> dict[str, list[tuple[float | None, dict]]]:
    """Return each entity's rows ``(t or None if static, {component: value})`` in time order."""
    rows: dict[str, list[tuple[float | None, dict]]] = defaultdict(list)
    for chunk in RrdReader(path).stream():
        batch = chunk.to_record_batch()
        table = {name: batch.column(name).to_pylist() for name in batch.schema.names}
        stamps = table.pop(TIMELINE, None)
        times = [None] * batch.num_rows if stamps is None else [d.total_seconds() for d in stamps]
        for i, t in enumerate(times):
            rows[chunk.entity_path].append((t, {k: v[i] for k, v in table.items() if v[i]}))
    return {
        e: sorted(r, key=lambda row: -np.inf if row[0] is None else row[0]) for e, r in rows.items()
    }


def column(rows: list[tuple[float | None, dict]], component: str) -> tuple[list, list]:
    """Return the times and values of ``component`` in ``rows`` (``rows`` of :func:`read_rrd`)."""
    found = [(t, values[component]) for t, values in rows if component in values]
    return [t for t, _ in found], [v for _, v in found]


def _run(n: int = 50) -> tuple[WheelLog, OdometryResult]:
    """Return a log of ``n`` rows at 10 Hz (poses every 5th row) and a result of known states."""
    t = 100.0 + 0.1 * np.arange(n)
    pose = np.full((n, 3), np.nan)
    pose[::5] = np.column_stack((t, -t, np.zeros(n)))[::5]
    log = WheelLog(t, np.ones(n), np.ones(n), pose, None, np.zeros(n, dtype=int))
    states = np.column_stack([t * (i + 1) for i in range(len(NAMES))])
    states[:, 2] = np.linspace(-3.0, 3.0, n)  # yaw
    stds = np.full_like(states, 0.25)
    terrain = np.array(["grass"] * 20 + ["gravel"] * (n - 20))
    changes = [TerrainChange(float(t[20]), "grass", "gravel", restored=True, t_confirmed=101.5)]
    return log, OdometryResult(NAMES, states, stds, terrain, changes)


def _frames() -> list[RecordedFrame]:
    polygon = np.array([[10.0, 200.0], [300.0, 200.0], [200.0, 100.0], [100.0, 100.0]])
    tiles = np.array([[100, 100, 132, 132], [132, 100, 164, 132]])
    return [
        RecordedFrame(
            100.5,
            JPEG,
            "image/jpeg",
            "grass",
            0.5,
            (10, 100, 300, 200),
            polygon,
            tiles,
            ["grass", "gravel"],
        ),  # fmt: skip
        RecordedFrame(101.0, JPEG, "image/jpeg", "", float("nan")),  # region outside the frame
    ]


@pytest.fixture(scope="module")
def recorded(
    tmp_path_factory: pytest.TempPathFactory,
) -> tuple[dict, WheelLog, OdometryResult, Path]:
    log, result = _run()
    path = tmp_path_factory.mktemp("rrd") / "run.rrd"
    handle = io.BytesIO()
    assert record_run(handle, log, result, _frames(), labels=["asphalt"], arrow=0.5) == 2
    path.write_bytes(handle.getvalue())
    return read_rrd(path), log, result, path


def test_every_state_is_a_series_on_the_log_time_with_its_two_sigma_band(recorded):
    rows, log, result, _ = recorded
    for i, name in enumerate(NAMES):
        for part, offset in (("lower", -0.5), ("estimate", 0.0), ("upper", 0.5)):
            t, values = column(rows[f"/states/{name}/{part}"], "Scalars:scalars")
            np.testing.assert_allclose(t, log.t, rtol=1e-12)
            np.testing.assert_allclose(np.array(values)[:, 0], result.states[:, i] + offset)
    assert column(rows["/states/y_l/estimate"], "SeriesLines:names") == ([None], [["y_l"]])


def test_the_robot_moves_along_the_estimate_and_turns_with_its_yaw(recorded):
    rows, log, result, _ = recorded
    t, translation = column(rows["/world/robot"], "Transform3D:translation")
    np.testing.assert_allclose(t, log.t, rtol=1e-12)
    xyz = np.array([value[0] for value in translation])
    np.testing.assert_allclose(xyz, np.column_stack((result.states[:, :2], np.zeros(len(log)))))
    _, quaternion = column(rows["/world/robot"], "Transform3D:quaternion")
    x, y, z, w = np.array([value[0] for value in quaternion]).T
    forward = np.column_stack((1 - 2 * (y**2 + z**2), 2 * (x * y + w * z)))  # R @ (1, 0, 0)
    yaw = result.states[:, 2]
    np.testing.assert_allclose(forward, np.column_stack((np.cos(yaw), np.sin(yaw))), atol=1e-6)
    assert column(rows["/world/robot"], "Arrows3D:vectors")[1] == [[[0.5, 0.0, 0.0]]]
    assert column(rows["/world"], "ViewCoordinates:xyz")[0] == [None]  # static: z up


def _rgba(colours: dict[str, str], names: list[str]) -> list[int]:
    return [int(colours[name][1:], 16) << 8 | 255 for name in names]


def test_the_path_is_one_strip_per_terrain_run_in_the_plot_colours(recorded):
    rows, log, result, _ = recorded
    _, [strips] = column(rows["/world/path"], "LineStrips3D:strips")
    assert [len(s) for s in strips] == [21, 30]  # the second starts where the first ends
    np.testing.assert_allclose(np.array(strips[1])[:, :2], result.states[20:, :2], rtol=1e-6)
    assert column(rows["/world/path"], "LineStrips3D:labels")[1] == [["grass", "gravel"]]
    colours = terrain_colours(["asphalt", "grass", "gravel"])
    assert column(rows["/world/path"], "LineStrips3D:colors")[1] == [
        _rgba(colours, ["grass", "gravel"])
    ]
    _, [measured] = column(rows["/world/measured"], "Points3D:positions")
    np.testing.assert_allclose(np.array(measured)[:, :2], log.pose[::5, :2], rtol=1e-6)


def test_the_terrain_log_says_where_the_run_starts_and_each_change(recorded):
    rows, log, *_ = recorded
    t, text = column(rows["/terrain"], "TextLog:text")
    assert t == pytest.approx([log.t[0], log.t[20]])
    assert text == [
        ["start on grass"],
        ["grass -> gravel (confirmed at 101.50 s): covariance reset, remembered ICRs restored"],
    ]


def test_the_recording_has_one_timeline_the_log_time(recorded):
    path = recorded[-1]
    assert {name for chunk in RrdReader(path).stream() for name in chunk.timeline_names} == {"t"}


def test_each_frame_shows_its_image_region_footprint_and_votes_or_clears_them(recorded):
    rows, *_ = recorded
    t, blobs = column(rows["/camera/image"], "EncodedImage:blob")
    assert t == [100.5, 101.0] and bytes(blobs[0][0]) == JPEG
    assert column(rows["/camera/image"], "EncodedImage:media_type")[1] == [["image/jpeg"]] * 2
    for entity in ("/camera/roi", "/camera/footprint", "/camera/tiles"):
        # shown with the first frame, cleared with the second (its region lies outside)
        assert column(rows[entity], "Clear:is_recursive") == ([101.0], [[False]]), entity
    assert column(rows["/camera/roi"], "Boxes2D:labels") == ([100.5], [["grass 50%"]])
    assert column(rows["/camera/roi"], "Boxes2D:centers")[1] == [[[155.0, 100.0 + 50.0]]]
    assert column(rows["/camera/roi"], "Boxes2D:half_sizes")[1] == [[[145.0, 50.0]]]
    _, [[footprint]] = column(rows["/camera/footprint"], "LineStrips2D:strips")
    assert len(footprint) == 5 and footprint[0] == footprint[-1]  # the polygon, closed
    colours = terrain_colours(["asphalt", "grass", "gravel"])
    tiles = column(rows["/camera/tiles"], "Boxes2D:colors")
    assert tiles == ([100.5], [_rgba(colours, ["grass", "gravel"])])
    _, [[first, second]] = column(rows["/camera/tiles"], "Boxes2D:centers")
    assert (first, second) == ([116.0, 116.0], [148.0, 116.0])
