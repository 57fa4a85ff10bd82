"""Tests of :mod:`terrain_odom.app.run`, the Python API behind the command line."""

from __future__ import annotations

import csv
import json
import time
from pathlib import Path

import numpy as np
import pytest

import terrain_odom.app.run as workflows
import terrain_odom.app.run_stream as stream
from terrain_odom.app.evaluate import evaluate
from terrain_odom.app.inputs import TerrainSource
from terrain_odom.app.run import RunOptions, RunSummary, run
from terrain_odom.cli.main import main
from terrain_odom.config import Config, load_config
from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.estimation.online import OnlineOdometry
from terrain_odom.io import read_trajectory_csv
from terrain_odom.kinematics import integrate, twist_icr

N_ROWS = 200
RATE_HZ = 20.0
TRUE_ICR = {"y_l": 0.4, "y_r": -0.35, "x_icr": 0.1}
INTERRUPT_AFTER = 100
"""Rows done before the interrupt: those before the label change (see the interrupt test)."""


def synthetic_log(path: Path, *, n: int = N_ROWS) -> dict[str, np.ndarray]:
    """Write a log of a robot driving arcs (exact ICR kinematics); poses every other row."""
    t = np.arange(n) / RATE_HZ
    phase = 2.0 * np.pi * t / 6.0
    v_l = 0.9 + 0.4 * np.sin(phase)
    v_r = 1.1 - 0.4 * np.sin(phase)
    v_x, v_y, omega = twist_icr(v_l[:-1], v_r[:-1], **TRUE_ICR)
    poses = integrate(v_x, v_y, omega, np.diff(t), start=[1.0, -2.0, 0.3])
    with open(path, "w", encoding="utf-8", newline="") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(["t", "v_l", "v_r", "x", "y", "yaw", "terrain"])
        for k in range(n):
            pose = [repr(float(v)) for v in poses[k]] if k % 2 == 0 else ["", "", ""]
            label = "grass" if k < n // 2 else "asphalt"
            speeds = [repr(float(t[k])), repr(float(v_l[k])), repr(float(v_r[k]))]
            writer.writerow([*speeds, *pose, label])
    return {"t": t, "poses": poses}


@pytest.fixture
def log_path(tmp_path: Path) -> Path:
    path = tmp_path / "log.csv"
    synthetic_log(path)
    return path


def test_run_returns_summary_with_existing_paths(log_path: Path, tmp_path: Path) -> None:
    out_dir = tmp_path / "nested" / "out"  # parents are created

    started = time.perf_counter()
    summary = run(log_path, out_dir, RunOptions(progress=False))
    wall = time.perf_counter() - started

    assert isinstance(summary, RunSummary)
    assert summary.report.counts.rows == N_ROWS
    assert 0.0 < summary.report.run_time_s <= wall  # the run's own clock, inside the call
    assert summary.trajectory_csv == out_dir / "trajectory.csv"
    assert summary.trajectory_tum == out_dir / "trajectory.tum"
    assert summary.report_json == out_dir / "report.json"
    assert summary.report_md == out_dir / "report.md"
    for path in (summary.trajectory_csv, summary.trajectory_tum, summary.report_json):
        assert path.is_file(), path
    assert summary.config_yaml == out_dir / "config.yaml"
    assert sorted(p.name for p in out_dir.iterdir()) == [
        ".terrain-odom.json",  # the folder's manifest: what wrote which file
        "config.yaml",
        "plots",  # every run draws its trajectory and states
        "report.json",
        "report.md",
        "trajectory.csv",
        "trajectory.tum",
    ]
    traj = read_trajectory_csv(summary.trajectory_csv)
    assert len(traj["t"]) == N_ROWS
    tum_lines = summary.trajectory_tum.read_text(encoding="utf-8").splitlines()
    assert tum_lines[0].startswith("#")
    assert len(tum_lines) == N_ROWS + 1
    report = json.loads(summary.report_json.read_text(encoding="utf-8"))
    assert report["counts"]["rows"] == summary.report.counts.rows
    assert report["run_time_s"] == summary.report.run_time_s  # the same float, written exactly


def test_run_without_alpha_has_no_alpha_columns(log_path: Path, tmp_path: Path) -> None:
    cfg_path = tmp_path / "no_alpha.yaml"
    cfg_path.write_text("ekf:\n  estimate_alpha: false\n", encoding="utf-8")

    summary = run(log_path, tmp_path / "out", RunOptions(config_path=cfg_path, progress=False))

    header = summary.trajectory_csv.read_text(encoding="utf-8").splitlines()[0]
    assert header == "t,x,y,yaw,y_l,y_r,x_icr,terrain,std_x,std_y,std_yaw,std_y_l,std_y_r,std_x_icr"
    report = json.loads(summary.report_json.read_text(encoding="utf-8"))
    assert "alpha" not in report["final_state"]
    assert report["config"]["ekf"]["estimate_alpha"] is False


def interrupt_second_stretch(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """Make Ctrl-C strike at the second stretch of rows; return the stretches' lengths seen."""
    real = OnlineOdometry.rows
    stretches: list[int] = []

    def interrupted(self, t, *args, **kwargs):  # type: ignore[no-untyped-def]
        stretches.append(len(t))
        if len(stretches) == 2:
            raise KeyboardInterrupt
        return real(self, t, *args, **kwargs)

    monkeypatch.setattr(OnlineOdometry, "rows", interrupted)
    return stretches


def test_interrupted_run_keeps_streamed_rows(
    log_path: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """KeyboardInterrupt in the middle: trajectory.csv holds every row done, no TUM file.

    The synthetic log runs as two stretches (rows 0-99, from the segment's
    start; rows 100-199 from the label change on): Ctrl-C during the second
    leaves the first 100 rows, equal to those of an uninterrupted run, and
    report.json says so.
    """
    complete = run(log_path, tmp_path / "complete", RunOptions(progress=False))
    whole = read_trajectory_csv(complete.trajectory_csv)
    stretches = interrupt_second_stretch(monkeypatch)
    out_dir = tmp_path / "out"

    with pytest.raises(KeyboardInterrupt):
        run(log_path, out_dir, RunOptions(progress=False))

    assert stretches == [INTERRUPT_AFTER, N_ROWS - INTERRUPT_AFTER]
    traj = read_trajectory_csv(out_dir / "trajectory.csv")
    assert len(traj["t"]) == INTERRUPT_AFTER
    for name, column in whole.items():
        np.testing.assert_array_equal(traj[name], column[:INTERRUPT_AFTER], err_msg=name)
    # the text ends with a complete line: no half-written row
    text = (out_dir / "trajectory.csv").read_text(encoding="utf-8")
    assert text.endswith("\n")
    assert len(text.splitlines()) == INTERRUPT_AFTER + 1
    # report.json says the run was interrupted, and after how many rows; no temp files
    report = json.loads((out_dir / "report.json").read_text(encoding="utf-8"))
    assert report["status"] == "interrupted"
    assert report["rows_written"] == INTERRUPT_AFTER
    assert report["reason"] == "interrupted by the user"
    assert report["inputs"]["wheels"] == str(log_path.resolve())
    assert sorted(p.name for p in out_dir.iterdir()) == [
        ".terrain-odom.json",
        "config.yaml",
        "report.json",
        "trajectory.csv",
    ]


def test_a_folder_holding_a_run_is_refused_unless_overwrite(
    log_path: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A second run into a run's folder is refused (nothing touched); --overwrite replaces it.

    The replacing run removes the first run's files before it starts, so
    when it is interrupted nothing of the first run is left to mix with it.
    """
    out_dir = tmp_path / "out"
    first = run(log_path, out_dir, RunOptions(progress=False))
    (out_dir / "notes.txt").write_text("mine", encoding="utf-8")
    before = {p.relative_to(out_dir): p.read_bytes() for p in out_dir.rglob("*") if p.is_file()}

    with pytest.raises(InputFileError, match="already holds a run .*--overwrite"):
        run(log_path, out_dir, RunOptions(progress=False))
    assert {
        p.relative_to(out_dir): p.read_bytes() for p in out_dir.rglob("*") if p.is_file()
    } == before

    interrupt_second_stretch(monkeypatch)
    with pytest.raises(KeyboardInterrupt):
        run(log_path, out_dir, RunOptions(progress=False, overwrite=True))

    report = json.loads(first.report_json.read_text(encoding="utf-8"))
    assert report["status"] == "interrupted" and report["rows_written"] == INTERRUPT_AFTER
    assert len(read_trajectory_csv(out_dir / "trajectory.csv")["t"]) == INTERRUPT_AFTER
    # the first run's trajectory.tum and report.md are gone; the user's file is kept
    assert sorted(p.name for p in out_dir.iterdir()) == [
        ".terrain-odom.json",
        "config.yaml",
        "notes.txt",
        "report.json",
        "trajectory.csv",
    ]
    with pytest.raises(InputFileError, match="already holds an interrupted run"):
        run(log_path, out_dir, RunOptions(progress=False))


def test_a_completed_run_says_so(log_path: Path, tmp_path: Path) -> None:
    summary = run(log_path, tmp_path / "out", RunOptions(progress=False))
    report = json.loads(summary.report_json.read_text(encoding="utf-8"))
    assert report["status"] == "complete"


def test_report_embeds_the_config_used(log_path: Path, tmp_path: Path) -> None:
    cfg_path = tmp_path / "custom.yaml"
    cfg_path.write_text(
        "ekf:\n  sigma_r: {x: 0.123, yaw: 0.031}\nterrain:\n  confirm: 3\n", encoding="utf-8"
    )

    summary = run(log_path, tmp_path / "out", RunOptions(config_path=cfg_path, progress=False))

    report = json.loads(summary.report_json.read_text(encoding="utf-8"))
    assert report["inputs"]["config"] == str(cfg_path.resolve())
    sigma_r = report["config"]["ekf"]["sigma_r"]
    assert sigma_r == {"x": 0.123, "y": 0.05, "yaw": 0.031}  # y keeps the default
    assert report["config"]["terrain"]["confirm"] == 3
    assert report["config"]["robot"] == {"wheel_radius": 0.1, "track_width": 0.5, "length": None}
    # the config was really used: the pose anchor's std is sigma_r, and the change
    # is confirmed on the third 'asphalt' row
    traj = read_trajectory_csv(summary.trajectory_csv)
    assert traj["std_x"][0] == 0.123
    assert traj["std_yaw"][0] == 0.031
    (change,) = report["terrain_changes"]
    assert change["t"] == pytest.approx((N_ROWS // 2 + 2) / RATE_HZ, abs=1e-9)


def test_config_object_takes_precedence(log_path: Path, tmp_path: Path) -> None:
    cfg_path = tmp_path / "ignored.yaml"
    cfg_path.write_text("ekf:\n  sigma_r: {x: 0.5}\n", encoding="utf-8")
    config = Config()

    summary = run(
        log_path, tmp_path / "out", RunOptions(config=config, config_path=cfg_path, progress=False)
    )

    report = json.loads(summary.report_json.read_text(encoding="utf-8"))
    assert report["config"]["ekf"]["sigma_r"]["x"] == 0.05


def test_terrain_sources(log_path: Path, tmp_path: Path) -> None:
    none = run(log_path, tmp_path / "none", RunOptions(terrain=TerrainSource.NONE, progress=False))
    from_log = run(
        log_path, tmp_path / "log", RunOptions(terrain=TerrainSource.LOG, progress=False)
    )

    r_none = json.loads(none.report_json.read_text(encoding="utf-8"))
    r_log = json.loads(from_log.report_json.read_text(encoding="utf-8"))
    assert r_none["terrain_source"] == "none" and r_none["terrain_changes"] == []
    assert r_log["terrain_source"] == "log"
    assert [(c["previous"], c["label"]) for c in r_log["terrain_changes"]] == [("grass", "asphalt")]


def test_errors_are_package_errors(log_path: Path, tmp_path: Path) -> None:
    bad_cfg = tmp_path / "bad.yaml"
    bad_cfg.write_text("ekf:\n  sigma_p0: {x: 0}\n", encoding="utf-8")
    with pytest.raises(ConfigError, match=r"ekf\.sigma_p0\.x: must be > 0"):
        run(log_path, tmp_path / "a", RunOptions(config_path=bad_cfg, progress=False))
    with pytest.raises(InputFileError, match="does not exist"):
        run(tmp_path / "missing.csv", tmp_path / "b", RunOptions(progress=False))
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


def test_evaluate_returns_and_writes_result(log_path: Path, tmp_path: Path) -> None:
    summary = run(log_path, tmp_path / "run", RunOptions(progress=False))
    params = tmp_path / "true.yaml"
    params.write_text(
        "format_version: 1\nmodel: icr\nparams: {y_l: 0.4, y_r: -0.35, x_icr: 0.1}\n",
        encoding="utf-8",
    )

    result = evaluate(summary.report_json.parent, log_path, params=[params], horizon=1.5)

    on_disk = json.loads((tmp_path / "run" / "evaluation.json").read_text(encoding="utf-8"))
    assert on_disk == json.loads(json.dumps(result.to_dict()))
    assert result.horizon == 1.5
    assert result.run == (tmp_path / "run").resolve()
    assert list(result.models) == ["idd (B=0.5 m)", "ekf (online)", "icr (true.yaml)"]
    assert list(result.prediction) == ["idd (B=0.5 m)", "ekf (online)"]
    assert result.models["icr (true.yaml)"].errors.translation.median < 1e-6
    assert result.models["idd (B=0.5 m)"].errors.translation.median > 0.05


def test_load_config_default_is_builtin() -> None:
    assert load_config(None) == Config()


def test_cli_run_interrupted_keeps_rows_and_exits_130(
    log_path: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """``terrain-odom run`` interrupted: exit code 130, one line, the streamed rows kept."""
    interrupt_second_stretch(monkeypatch)
    out_dir = tmp_path / "out"

    code = main(["run", "--wheels", str(log_path), "--out", str(out_dir)])
    out, err = capsys.readouterr()

    assert code == 130
    assert out == ""
    assert err.splitlines() == ["terrain-odom: interrupted; outputs written so far are kept"]
    assert len(read_trajectory_csv(out_dir / "trajectory.csv")["t"]) == INTERRUPT_AFTER
    assert json.loads((out_dir / "report.json").read_text())["status"] == "interrupted"
    # evaluate refuses the interrupted run, in one line
    monkeypatch.undo()
    code = main(["evaluate", "--wheels", str(log_path), "--run", str(out_dir)])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err
    assert "the run did not complete (status: interrupted)" in err


def test_a_long_run_keeps_some_rows_in_memory_and_writes_every_row(
    log_path: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Past 2 x KEPT_ROWS rows the result keeps every k-th row: the files are those of all rows."""
    whole = run(log_path, tmp_path / "whole", RunOptions(progress=False))
    kept_rows = []
    real = stream.run_odometry

    def spy(*args, **kwargs):  # type: ignore[no-untyped-def]
        result = real(*args, **kwargs)
        kept_rows.append(result.rows)
        return result

    monkeypatch.setattr(workflows, "KEPT_ROWS", 40)
    monkeypatch.setattr(stream, "run_odometry", spy)
    part = run(log_path, tmp_path / "part", RunOptions(progress=False))
    np.testing.assert_array_equal(kept_rows[0], np.r_[np.arange(0, N_ROWS, 5), N_ROWS - 1])
    for name in ("trajectory.csv", "trajectory.tum"):
        assert (tmp_path / "part" / name).read_bytes() == (tmp_path / "whole" / name).read_bytes()
    reports = [json.loads(s.report_json.read_text(encoding="utf-8")) for s in (whole, part)]
    for report in reports:
        del report["run_time_s"]
    assert reports[0] == reports[1]
    assert [p.name for p in part.plots] == ["trajectory.png", "states.png"]
