"""The streaming API: call by call it is the row loop and ``terrain-odom run``."""

from __future__ import annotations

import csv
import dataclasses
from pathlib import Path

import numpy as np
import pytest

from terrain_odom import OnlineOdometry
from terrain_odom.app.inputs import read_calibrated_log
from terrain_odom.cli.main import main
from terrain_odom.config import Config, SlipEkfConfig, load_config
from terrain_odom.errors import ConfigError, EstimationError
from terrain_odom.estimation.icr_ekf import IcrEkf, IcrPriors
from terrain_odom.estimation.odometry import run_icr_ekf, run_slip_ekf
from terrain_odom.io import read_trajectory_csv
from terrain_odom.io.classifier_file import default_classifier, load_classifier
from terrain_odom.io.frames import read_frames
from terrain_odom.io.images import read_image_rgb
from terrain_odom.kinematics import integrate, twist_icr
from terrain_odom.records import WheelLog

REPO = Path(__file__).resolve().parents[2]
SAMPLE = REPO / "sample_images" / "chen2023"
TERRAIN_ICRS = {"grass": (0.42, -0.40, 0.05), "gravel": (0.55, -0.52, -0.03)}


def _simulated_log() -> WheelLog:
    """Three segments (the third restarts the clock), terrain changes, full and heading-only poses."""
    rng = np.random.default_rng(3)
    pieces = []
    for segment, (t0, n, terrains) in enumerate(
        [(0.0, 300, ("grass", "gravel")), (20.0, 200, ("gravel",)), (5.0, 250, ("gravel", "grass"))]
    ):
        t = t0 + np.arange(n) * 0.02
        v_l = 0.6 + 0.3 * np.sin(t / 1.3 + segment)
        v_r = 0.6 + 0.3 * np.cos(t / 0.9)
        terrain = np.where(np.arange(n) < n // 2, terrains[0], terrains[-1])
        icr = np.array([TERRAIN_ICRS[str(label)] for label in terrain])
        twist = np.array([twist_icr(a, b, *p) for a, b, p in zip(v_l, v_r, icr, strict=True)])
        truth = integrate(*twist[:-1].T, np.diff(t))  # shape (n, 3)
        pose = np.full((n, 3), np.nan)
        pose[::5] = truth[::5] + rng.normal(0.0, 0.01, (len(truth[::5]), 3))
        pose[2::10, 2] = truth[2::10, 2]  # heading only
        pieces.append((t, v_l, v_r, pose, terrain, np.full(n, segment)))
    t, v_l, v_r, pose, terrain, segment = (np.concatenate(p) for p in zip(*pieces, strict=True))
    return WheelLog(t, v_l, v_r, pose, terrain.astype(str), segment, "simulated")


def _stream(log: WheelLog, odo: OnlineOdometry, labels: bool = True) -> np.ndarray:
    """Feed a log call by call, as a robot would; return the state after every row."""
    rows = []
    label = None
    for k in range(len(log)):
        t = float(log.t[k])
        if labels and log.terrain is not None and log.terrain[k] != label:
            label = str(log.terrain[k])
            odo.terrain(t, label)
        new_segment = k > 0 and log.segment[k] != log.segment[k - 1]
        odo.wheels(t, float(log.v_l[k]), float(log.v_r[k]), new_segment=new_segment)
        if np.any(np.isfinite(log.pose[k])):
            odo.pose(t, *map(float, log.pose[k]))
        state = odo.state()
        rows.append([state[n] for n in odo.names] + [state[f"std_{n}"] for n in odo.names])
    return np.array(rows, dtype=float)


def test_calls_reproduce_the_icr_ekf_row_loop_exactly():
    log = _simulated_log()
    cfg = load_config()
    priors = IcrPriors(terrains={"gravel": cfg.ekf.initial.resolve(cfg.robot)})
    batch = run_icr_ekf(log, cfg, labels=log.terrain, priors=priors)
    assert len(batch.changes) >= 2  # grass -> gravel, gravel -> grass
    odo = OnlineOdometry(cfg, priors=priors)
    np.testing.assert_array_equal(_stream(log, odo), np.hstack([batch.states, batch.stds]))
    assert odo.changes == batch.changes and odo.n_updates == batch.n_updates
    assert odo.state()["terrain"] == batch.terrain[-1] == "grass"


def test_calls_reproduce_the_slip_ekf_row_loop_exactly():
    log = _simulated_log()
    cfg = dataclasses.replace(Config(), slip_ekf=SlipEkfConfig(window=0.3))
    batch = run_slip_ekf(log, cfg, labels=log.terrain)
    odo = OnlineOdometry(cfg, estimator="slip-ekf")
    np.testing.assert_array_equal(_stream(log, odo), np.hstack([batch.states, batch.stds]))
    assert odo.changes == batch.changes and odo.n_updates == batch.n_updates
    # the wheel history is a bounded buffer: the 0.3-s window (15 samples) plus the gaps
    # between headings, not the 750 rows of the log
    assert len(odo._steps._samples) <= 30


@pytest.mark.parametrize("estimator", ["icr-ekf", "slip-ekf"])
def test_calls_reproduce_the_cli_run_on_a_real_log(tmp_path, capsys, estimator, drive_dir):
    config = REPO / "config" / "warthog.yaml"
    drive_log = drive_dir / "warthog_wheels_grass.csv"
    out = tmp_path / "out"
    args = ["--wheels", str(drive_log), "--config", str(config), "--estimator", estimator]
    assert main(["run", *args, "--out", str(out)]) == 0
    capsys.readouterr()
    written = read_trajectory_csv(out / "trajectory.csv")
    odo = OnlineOdometry.from_config(config, estimator=estimator)
    log, _ = read_calibrated_log(drive_log, odo.config)
    streamed = _stream(log, odo)
    names = odo.names
    for i, name in enumerate(names):
        np.testing.assert_array_equal(streamed[:, i], written[name], err_msg=name)
        np.testing.assert_array_equal(
            streamed[:, len(names) + i], written[f"std_{name}"], err_msg=name
        )


def test_frames_reproduce_the_cli_frame_labels(sample_camera_run):
    out, _ = sample_camera_run  # run --images sample_images/chen2023 --wheels .../log.csv
    with (out / "frames.csv").open(newline="") as handle:
        expected = [(r["label"], r["confirmed_label"]) for r in csv.DictReader(handle)]
    cfg = load_config(SAMPLE / "config.yaml")
    odo = OnlineOdometry(cfg, load_classifier(default_classifier()))
    log, _ = read_calibrated_log(SAMPLE / "log.csv", cfg)
    frames = read_frames(SAMPLE)
    got = []
    i = int(np.searchsorted(frames.t, log.t[0]))  # frames before the first row are skipped
    for k in range(len(log)):
        t = float(log.t[k])
        odo.wheels(t, float(log.v_l[k]), float(log.v_r[k]))
        if np.any(np.isfinite(log.pose[k])):
            odo.pose(t, *map(float, log.pose[k]))
        end = float(log.t[k + 1]) if k + 1 < len(log) else np.nextafter(t, np.inf)
        while i < frames.t.size and frames.t[i] < end:
            image = read_image_rgb(frames.files[i])
            assert image is not None
            result = odo.frame(float(frames.t[i]), image)
            got.append((result.label, odo.seen_terrain))
            i += 1
    assert len(got) == len(expected) > 50
    assert got == expected
    assert len({label for label, _ in got}) >= 2  # a terrain change is seen


def test_bad_calls_raise_one_line_errors_naming_the_value():
    odo = OnlineOdometry(Config())
    with pytest.raises(EstimationError, match="no wheel speeds yet"):
        odo.pose(0.0, 0.0, 0.0, 0.0)
    with pytest.raises(ValueError, match=r"v_r=nan is not finite"):
        odo.wheels(0.0, 0.5, float("nan"))
    odo.wheels(1.0, 0.5, 0.5)
    with pytest.raises(EstimationError, match=r"wheels at t=0.5 s: time does not advance"):
        odo.wheels(0.5, 0.5, 0.5)
    with pytest.raises(EstimationError, match="the filter is at t=1.0 s"):
        odo.pose(1.5, yaw=0.1)
    with pytest.raises(ValueError, match="no finite component"):
        odo.pose(1.0)
    with pytest.raises(EstimationError, match="time goes backwards"):
        odo.sighting(0.9, None)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="needs a terrain classifier"):
        odo.frame(1.0, np.zeros((2, 2, 3), dtype=np.uint8))
    with pytest.raises(ConfigError, match="unknown estimator"):
        OnlineOdometry(Config(), estimator="kalman")  # type: ignore[arg-type]
    odo.wheels(0.5, 0.5, 0.5, new_segment=True)  # a new segment may restart the clock
    assert odo.t == 0.5
    for message in ("no wheel speeds yet", "is not finite", "time does not advance"):
        assert "\n" not in message


def test_a_label_takes_effect_once_the_filter_reaches_its_time():
    cfg = Config()
    odo = OnlineOdometry(cfg)
    odo.wheels(0.0, 0.5, 0.5)
    odo.terrain(0.1, "grass")  # not reached yet
    assert odo.state()["terrain"] == ""
    odo.wheels(0.1, 0.5, 0.5)
    assert odo.state()["terrain"] == "grass"
    odo.terrain(0.2, "sand")
    for t in (0.2, 0.3, 0.4)[: cfg.terrain.confirm]:
        odo.wheels(t, 0.5, 0.5)
    assert odo.state()["terrain"] == "sand" and [c.label for c in odo.changes] == ["sand"]


def test_measured_rows_on_booleans_follow_the_public_rule():
    """The pose path's rows on Python booleans equal ``measured_rows`` for every pattern."""
    from itertools import product

    from terrain_odom.estimation.online import _measured_rows
    from terrain_odom.estimation.pose_measurement import measured_rows

    for finite in product([False, True], repeat=3):
        z = [1.0 if f else float("nan") for f in finite]
        assert _measured_rows(list(finite)) == tuple(measured_rows(z).tolist())


def _rows_against_calls(log: WheelLog, cfg: Config) -> tuple[OnlineOdometry, OnlineOdometry]:
    """Feed ``log`` (one segment) through rows() in stretches, and call by call; compare."""
    by_rows, by_calls = OnlineOdometry(cfg), OnlineOdometry(cfg)
    by_rows.terrain(float(log.t[0]), "grass")
    by_calls.terrain(float(log.t[0]), "grass")
    got = [by_rows.rows(log.t[s], log.v_l[s], log.v_r[s], log.pose[s]) for s in _stretches(log)]
    states = np.vstack([g[0] for g in got])
    stds = np.vstack([g[1] for g in got])
    expected = _stream(log, by_calls, labels=False)
    n = len(by_rows.names)
    np.testing.assert_array_equal(states, expected[:, :n])
    np.testing.assert_array_equal(stds, expected[:, n:])
    assert {str(label) for g in got for label in g[2]} == {"grass"}
    return by_rows, by_calls


def _stretches(log: WheelLog) -> list[slice]:
    """Stretches of 1, 7, 300 and the remaining rows."""
    cuts = [0, 1, 8, 308, len(log)]
    return [slice(a, b) for a, b in zip(cuts[:-1], cuts[1:], strict=True)]


@pytest.mark.parametrize("kernels", ["python", "compiled"], indirect=True)
def test_rows_equal_the_calls_one_by_one_on_a_real_log(
    drive_dir, warthog_yaml, kernels, monkeypatch
):
    """Stretches in one kernel call (once anchored) give the bits of wheels/pose/estimate."""
    cfg = load_config(warthog_yaml)
    log = read_calibrated_log(drive_dir / "warthog_wheels_grass.csv", cfg)[0]
    log = dataclasses.replace(log, segment=np.zeros(len(log), dtype=log.segment.dtype))
    in_one_call = []
    run_rows = IcrEkf.run_rows

    def counted(self, since, t, *args):  # type: ignore[no-untyped-def]
        in_one_call.append(len(t))
        return run_rows(self, since, t, *args)

    monkeypatch.setattr(IcrEkf, "run_rows", counted)
    by_rows, by_calls = _rows_against_calls(log, cfg)
    assert sum(in_one_call) > 0.99 * len(log)  # all but the rows before the anchoring
    assert by_rows.n_updates == by_calls.n_updates > 1000
    assert by_rows.pose_use == by_calls.pose_use
    assert by_rows._steps.filter.t == by_calls._steps.filter.t
    assert by_rows._steps.filter.last_nis == by_calls._steps.filter.last_nis
    assert by_rows.state() == by_calls.state()


def test_rows_count_unpaired_positions_and_heading_only_rows_as_the_calls_do():
    """Unpaired x or y and heading-only rows: the same drops, updates and estimates."""
    log = _simulated_log()
    n = 300  # the first segment
    pose = log.pose[:n].copy()
    pose[40::25, 1] = np.nan  # x without y
    pose[45::25, 0] = np.nan  # y without x
    one = WheelLog(log.t[:n], log.v_l[:n], log.v_r[:n], pose, None, np.zeros(n, int), "sim")
    by_rows, by_calls = _rows_against_calls(one, Config())
    assert by_rows.pose_use == by_calls.pose_use
    assert by_rows.pose_use.dropped["position: x without y (or y without x)"] >= 20
    assert by_rows.n_updates == by_calls.n_updates


def test_rows_at_fault_raise_what_the_calls_raise_at_that_row():
    log = _simulated_log()
    odo = OnlineOdometry(Config())
    odo.rows(log.t[:50], log.v_l[:50], log.v_r[:50], log.pose[:50])  # anchored by now
    t = log.t[50:100].copy()
    t[30] = t[29]  # time stands still
    with pytest.raises(EstimationError, match=r"wheels at t=.* time does not advance"):
        odo.rows(t, log.v_l[50:100], log.v_r[50:100], log.pose[50:100])
    assert odo.t == t[29]  # the rows before the fault were taken
    v_l = log.v_l[100:120].copy()
    v_l[5] = np.inf
    with pytest.raises(ValueError, match="v_l=inf is not finite"):
        odo.rows(log.t[100:120], v_l, log.v_r[100:120], log.pose[100:120])
