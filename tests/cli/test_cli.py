"""Tests of the ``terrain-odom`` command line (:mod:`terrain_odom.cli.main`).

Most cases call :func:`terrain_odom.cli.main.main` in-process; a few start
``python -m terrain_odom`` in a subprocess to check what a user really sees
(exit code, one line on stderr, no traceback).
"""

from __future__ import annotations

import csv
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from terrain_odom.cli.main import main
from terrain_odom.io import read_trajectory_csv
from terrain_odom.kinematics import integrate, twist_icr

REPO = Path(__file__).resolve().parents[2]
SRC = REPO / "src"

N_ROWS = 200
RATE_HZ = 20.0
TRUE_ICR = {"y_l": 0.4, "y_r": -0.35, "x_icr": 0.1}
"""ICR parameters the synthetic log is generated with (no slip: alpha = 1)."""
CHANGE_ROW = N_ROWS // 2
"""First row labelled 'asphalt' (the rows before are 'grass')."""

HEADER = (
    "t,x,y,yaw,y_l,y_r,x_icr,terrain,alpha,std_x,std_y,std_yaw,std_y_l,std_y_r,std_x_icr,std_alpha"
)


def synthetic_log(path: Path, *, n: int = N_ROWS, terrain: bool = True, t0: float = 0.0) -> dict:
    """Write a log of a robot driving arcs, poses on every other row, and return its arrays.

    The poses are the exact integration of :func:`twist_icr` with ``TRUE_ICR``
    over the zero-order-held speeds of each row.
    """
    t = t0 + np.arange(n) / RATE_HZ
    phase = 2.0 * np.pi * (t - t0) / 6.0
    v_l = 0.9 + 0.4 * np.sin(phase)
    v_r = 1.1 - 0.4 * np.sin(phase)
    v_x, v_y, omega = twist_icr(v_l[:-1], v_r[:-1], **TRUE_ICR)
    poses = integrate(v_x, v_y, omega, np.diff(t), start=[1.0, -2.0, 0.3])
    labels = np.where(np.arange(n) < n // 2, "grass", "asphalt")
    with open(path, "w", encoding="utf-8", newline="") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(["t", "v_l", "v_r", "x", "y", "yaw"] + (["terrain"] if terrain else []))
        for k in range(n):
            pose = [repr(float(v)) for v in poses[k]] if k % 2 == 0 else ["", "", ""]
            row = [repr(float(t[k])), repr(float(v_l[k])), repr(float(v_r[k])), *pose]
            writer.writerow(row + ([str(labels[k])] if terrain else []))
    return {"t": t, "v_l": v_l, "v_r": v_r, "poses": poses, "labels": labels}


@pytest.fixture
def log_path(tmp_path: Path) -> Path:
    path = tmp_path / "log.csv"
    synthetic_log(path)
    return path


def run_main(capsys: pytest.CaptureFixture[str], *argv: str | Path) -> tuple[int, str, str]:
    """Call the CLI in-process; return exit code, stdout and stderr."""
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def assert_one_line_error(code: int, out: str, err: str, *fragments: str) -> str:
    """Exit code 2, nothing on stdout, one error line containing every fragment."""
    assert code == 2
    assert out == ""
    assert "Traceback" not in err
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert err.endswith("\n")
    line = lines[0]
    assert line.startswith("terrain-odom: error: "), line
    for fragment in fragments:
        assert fragment in line, (fragment, line)
    return line


def write(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


# --- bad input: one line, exit code 2 -------------------------------------------------

# (file text or None for a missing file, fragments the message must contain besides the path)
BAD_LOGS = {
    "missing-file": (None, ["does not exist"]),
    "empty-file": ("", ["file is empty"]),
    "header-only": ("t,v_l,v_r\n", ["line 1", "no data rows"]),
    "missing-t": ("time,v_l,v_r\n0,1,1\n0.05,1,1\n", ["line 1", "missing column 't'"]),
    "missing-wheel-speeds": (
        "t,left,right\n0,1,1\n0.05,1,1\n",
        ["line 1", "missing wheel-speed columns", "v_l,v_r"],
    ),
    "only-one-wheel-speed": ("t,v_l\n0,1\n0.05,1\n", ["line 1", "missing column 'v_r'"]),
    "non-numeric": (
        "t,v_l,v_r\n0,1,1\n0.05,1,1\n0.1,abc,1\n",
        ["line 4", "column 'v_l'", "'abc' is not a number"],
    ),
    "time-backwards": (
        "t,v_l,v_r\n0,1,1\n0.05,1,1\n0.1,1,1\n0.08,1,1\n",
        ["line 5", "column 't'", "0.08", "not after 0.1", "line 4"],
    ),
    "nan-wheel-speed": (
        "t,v_l,v_r\n0,1,1\n0.05,1,nan\n",
        ["line 3", "column 'v_r'", "not a finite number"],
    ),
}


@pytest.mark.parametrize("case", sorted(BAD_LOGS))
def test_bad_wheel_log_is_one_line_and_exit_2(
    case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text, fragments = BAD_LOGS[case]
    wheels = tmp_path / f"{case}.csv"
    if text is not None:
        write(wheels, text)
    out_dir = tmp_path / "out"

    code, out, err = run_main(capsys, "run", "--wheels", wheels, "--out", out_dir)

    assert_one_line_error(code, out, err, str(wheels), *fragments)
    assert not out_dir.exists()  # nothing is created before the inputs are validated


BAD_FILES = [
    (
        "config",
        "ekf:\n  sigma_r: {x: 0.05, bogus_key: 1.0}\n",
        ["ekf.sigma_r", "unknown key", "bogus_key"],
    ),
    ("config", "robot: {wheel_radius: 0.1}\nfoo: 1\n", ["unknown key", "'foo'"]),
    ("config", "ekf:\n  sigma_r: {x: -0.05}\n", ["ekf.sigma_r.x", "must be > 0", "-0.05"]),
    ("config", "ekf:\n  sigma_q: {yaw: -1}\n", ["ekf.sigma_q.yaw", "must be >= 0"]),
    (
        "params",
        "format_version: 1\nmodel: icr\nparams: {y_l: 0.4, y_r: -0.35, x_icr: 0.1}\nwidth: 1\n",
        ["unknown key", "'width'"],
    ),
    (
        "params",
        "format_version: 1\nmodel: icr\nparams: {y_l: 0.4, y_r: -0.35, xicr: 0.1}\n",
        ["model 'icr' needs params", "'x_icr'", "'xicr'"],
    ),
    ("params", "format_version: 1\nmodel: nope\nparams: {}\n", ["unknown kinematic model 'nope'"]),
]
"""A bad configuration (given to ``run``) or parameter file (to ``evaluate``), and
what its error message must name."""


@pytest.mark.parametrize(
    ("kind", "yaml_text", "fragments"),
    BAD_FILES,
    ids=[
        "config-unknown-nested-key",
        "config-unknown-top-key",
        "config-negative-sigma-r",
        "config-negative-sigma-q",
        "params-unknown-key",
        "params-wrong-param-name",
        "params-unknown-model",
    ],
)
def test_bad_yaml_file_names_the_key(
    kind: str,
    yaml_text: str,
    fragments: list[str],
    log_path: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    bad = write(tmp_path / f"{kind}.yaml", yaml_text)
    if kind == "config":
        output = tmp_path / "out"
        argv = ["run", "--wheels", log_path, "--out", output, "--config", bad]
    else:
        output = tmp_path / "evaluated"
        argv = ["evaluate", "--wheels", log_path, "--params", bad, "--out", output]

    code, out, err = run_main(capsys, *argv)

    assert_one_line_error(code, out, err, str(bad), *fragments)
    assert not output.exists()


def test_missing_config_file(
    log_path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "nope.yaml"
    code, out, err = run_main(
        capsys, "run", "--wheels", log_path, "--out", tmp_path / "out", "--config", config
    )
    assert_one_line_error(code, out, err, str(config), "not found")


def test_terrain_from_log_needs_a_terrain_column(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    wheels = tmp_path / "no_terrain.csv"
    synthetic_log(wheels, terrain=False)
    out_dir = tmp_path / "out"

    code, out, err = run_main(
        capsys, "run", "--wheels", wheels, "--out", out_dir, "--terrain-from-log"
    )

    assert_one_line_error(code, out, err, str(wheels), "--terrain-from-log", "'terrain' column")
    assert not out_dir.exists()


def test_terrain_options_are_mutually_exclusive(
    log_path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as info:
        main(
            [
                "run",
                "--wheels",
                str(log_path),
                "--out",
                str(tmp_path / "out"),
                "--terrain-from-log",
                "--no-terrain",
            ]
        )
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "not allowed with argument" in err
    assert "--terrain-from-log" in err and "--no-terrain" in err
    assert not (tmp_path / "out").exists()


def test_evaluate_run_dir_without_trajectory(
    log_path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run_dir = tmp_path / "empty_run"
    run_dir.mkdir()

    code, out, err = run_main(capsys, "evaluate", "--run", run_dir, "--wheels", log_path)

    assert_one_line_error(code, out, err, str(run_dir / "trajectory.csv"), "no trajectory.csv")
    assert not (run_dir / "evaluation.json").exists()


@pytest.mark.parametrize("other", ["fewer-rows", "shifted-times"])
def test_evaluate_run_of_another_log_is_rejected(
    other: str, log_path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run_dir = tmp_path / "run"
    assert run_main(capsys, "run", "--wheels", log_path, "--out", run_dir)[0] == 0
    other_log = tmp_path / "other.csv"
    if other == "fewer-rows":
        synthetic_log(other_log, n=120)
        expected = ["its 200 rows", "the 120 rows", str(other_log)]
    else:
        synthetic_log(other_log, t0=3.0)
        expected = ["its 200 rows", "the 200 rows", str(other_log)]

    code, out, err = run_main(capsys, "evaluate", "--run", run_dir, "--wheels", other_log)

    assert_one_line_error(
        code, out, err, str(run_dir / "trajectory.csv"), "do not match", *expected
    )
    assert not (run_dir / "evaluation.json").exists()


def test_run_out_is_an_existing_file(
    log_path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    not_a_dir = write(tmp_path / "afile", "keep me\n")
    code, out, err = run_main(capsys, "run", "--wheels", log_path, "--out", not_a_dir)
    assert_one_line_error(code, out, err, str(not_a_dir))
    assert not_a_dir.read_text() == "keep me\n"


def test_evaluate_out_in_missing_directory_names_the_given_path(
    log_path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    target = tmp_path / "no_such_dir" / "evaluation.json"  # the old form: a file
    code, out, err = run_main(capsys, "evaluate", "--wheels", log_path, "--out", target)
    err = "".join(line for line in err.splitlines(keepends=True) if "warning:" not in line)
    line = assert_one_line_error(code, out, err)
    assert ".tmp" not in line
    assert str(target) in line or str(target.parent) in line


# --- the same through a real process ---------------------------------------------------


def run_process(*argv: str | Path, cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    return subprocess.run(
        [sys.executable, "-m", "terrain_odom", *map(str, argv)],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )


def assert_process_error(proc: subprocess.CompletedProcess[str], *fragments: str) -> None:
    assert proc.returncode == 2, proc.stderr
    assert proc.stdout == ""
    assert "Traceback" not in proc.stderr and "Traceback" not in proc.stdout
    lines = proc.stderr.splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("terrain-odom: error:")
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])


def test_process_non_numeric_cell(tmp_path: Path) -> None:
    write(tmp_path / "log.csv", "t,v_l,v_r\n0,1,1\n\n0.05,1,oops\n")  # the empty line counts
    proc = run_process("run", "--wheels", "log.csv", "--out", "out", cwd=tmp_path)
    assert_process_error(proc, "log.csv, line 4, column 'v_r'", "'oops' is not a number")
    assert not (tmp_path / "out").exists()


def test_process_invalid_config(log_path: Path, tmp_path: Path) -> None:
    write(tmp_path / "cfg.yaml", "terrain:\n  confirm: 2\n  colour: green\n")
    proc = run_process(
        "run", "--wheels", log_path, "--out", "out", "--config", "cfg.yaml", cwd=tmp_path
    )
    assert_process_error(proc, "cfg.yaml", "terrain", "unknown key", "'colour'")


def test_process_evaluate_without_trajectory(log_path: Path, tmp_path: Path) -> None:
    (tmp_path / "run").mkdir()
    proc = run_process("evaluate", "--run", "run", "--wheels", log_path, cwd=tmp_path)
    assert_process_error(proc, "trajectory.csv", "no trajectory.csv")


# --- good path -------------------------------------------------------------------------


def test_run_writes_trajectory_tum_and_report(
    log_path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from evo.tools.file_interface import read_tum_trajectory_file

    data = synthetic_log(log_path)  # same file again, to get the arrays
    out_dir = tmp_path / "out"

    code, out, err = run_main(capsys, "run", "--wheels", log_path, "--out", out_dir)

    assert code == 0, err
    assert err == ""
    lines = out.splitlines()
    assert lines[0].startswith(f"{N_ROWS} rows in ")
    assert f"trajectory: {out_dir / 'trajectory.csv'}" in lines
    report_lines = [line for line in lines if line.startswith("report:")]
    assert len(report_lines) == 1
    assert report_lines[0].split(None, 1)[1] == str(out_dir / "report.json")

    # trajectory.csv: exact header, one row per log row, the log's times
    csv_path = out_dir / "trajectory.csv"
    assert csv_path.read_text(encoding="utf-8").splitlines()[0] == HEADER
    traj = read_trajectory_csv(csv_path)
    assert list(traj) == HEADER.split(",")
    assert len(traj["t"]) == N_ROWS
    np.testing.assert_array_equal(traj["t"], data["t"])
    np.testing.assert_array_equal(
        traj["terrain"], ["grass"] * (CHANGE_ROW + 1) + ["asphalt"] * (N_ROWS - CHANGE_ROW - 1)
    )
    for name in HEADER.split(","):
        if name != "terrain":
            assert np.isfinite(traj[name]).all(), name
    # row 0 is anchored on the first measured pose
    np.testing.assert_allclose([traj["x"][0], traj["y"][0], traj["yaw"][0]], data["poses"][0])
    # the filter tracks the synthetic trajectory closely at the end
    np.testing.assert_allclose([traj["x"][-2], traj["y"][-2]], data["poses"][-2, :2], atol=0.05)

    # trajectory.tum: readable by evo, same poses
    tum = read_tum_trajectory_file(str(out_dir / "trajectory.tum"))
    assert tum.num_poses == N_ROWS
    np.testing.assert_allclose(tum.timestamps, data["t"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(tum.positions_xyz[:, 0], traj["x"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(tum.positions_xyz[:, 1], traj["y"], rtol=0, atol=1e-12)
    assert np.all(tum.positions_xyz[:, 2] == 0.0)

    # report.json
    report = json.loads((out_dir / "report.json").read_text(encoding="utf-8"))
    assert report["command"] == "run"
    assert report["terrain_source"] == "auto"
    assert report["inputs"]["wheels"] == str(log_path.resolve())
    assert report["inputs"]["config"] is None
    counts = report["counts"]
    assert counts["rows"] == N_ROWS
    assert counts["pose_measurements"] == N_ROWS // 2
    assert counts["updates"] == N_ROWS // 2 - 1  # the first pose anchors, the others update
    assert counts["terrain_changes"] == 1
    assert counts["segments"] == 1
    (change,) = report["terrain_changes"]
    assert change["previous"] == "grass"
    assert change["label"] == "asphalt"
    assert change["reset"] is True and change["restored"] is False
    # confirm = 2: confirmed on the second consecutive 'asphalt' row
    assert change["t"] == pytest.approx(data["t"][CHANGE_ROW + 1], abs=1e-9)
    assert isinstance(report["run_time_s"], float)
    assert 0.0 < report["run_time_s"] < 60.0
    assert report["config"]["terrain"]["confirm"] == 2
    assert report["config"]["ekf"]["estimate_alpha"] is True
    for name, value in report["final_state"].items():
        assert value == pytest.approx(traj[name][-1], rel=0, abs=1e-12), name


def test_run_terrain_from_log(
    log_path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out_dir = tmp_path / "out"
    code, _, err = run_main(
        capsys, "run", "--wheels", log_path, "--out", out_dir, "--terrain-from-log"
    )
    assert code == 0, err
    report = json.loads((out_dir / "report.json").read_text(encoding="utf-8"))
    assert report["terrain_source"] == "log"
    assert [(c["previous"], c["label"]) for c in report["terrain_changes"]] == [
        ("grass", "asphalt")
    ]


def test_run_no_terrain(log_path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out_dir = tmp_path / "out"

    code, _, err = run_main(capsys, "run", "--wheels", log_path, "--out", out_dir, "--no-terrain")

    assert code == 0, err
    with open(out_dir / "trajectory.csv", encoding="utf-8", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == N_ROWS
    assert {row["terrain"] for row in rows} == {""}
    report = json.loads((out_dir / "report.json").read_text(encoding="utf-8"))
    assert report["terrain_changes"] == []
    assert report["counts"]["terrain_changes"] == 0
    assert report["terrain_source"] == "none"


def _table(out: str) -> dict[str, str]:
    """Model name -> its line of the evaluate table."""
    rows = {}
    for line in out.splitlines()[2:]:
        if not line:  # the 2-s prediction table follows
            break
        name = line[:32].rstrip()
        rows[name] = line
    return rows


def test_evaluate_prints_table_and_writes_json(
    log_path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run_dir = tmp_path / "run"
    assert run_main(capsys, "run", "--wheels", log_path, "--out", run_dir)[0] == 0

    code, out, err = run_main(capsys, "evaluate", "--run", run_dir, "--wheels", log_path)

    assert code == 0, err
    assert err == ""
    result = json.loads((run_dir / "evaluation.json").read_text(encoding="utf-8"))
    assert result["command"] == "evaluate"
    assert result["horizon_m"] == 2.0
    assert result["run"] == str(run_dir.resolve())
    assert list(result["models"]) == ["idd (B=0.5 m)", "ekf (online)"]
    lines = out.splitlines()
    assert lines[0] == f"{result['windows']} windows of 2 m on {log_path}"
    assert result["windows"] > 50
    table = _table(out)
    assert list(table) == ["idd (B=0.5 m)", "ekf (online)"]
    idd = result["models"]["idd (B=0.5 m)"]["translation_m_per_m"]
    ekf = result["models"]["ekf (online)"]["translation_m_per_m"]
    assert table["idd (B=0.5 m)"].split()[3] == f"{idd['median']:.4f}"
    assert table["ekf (online)"].split()[2] == f"{ekf['median']:.4f}"
    assert idd["count"] == ekf["count"] == result["windows"]
    # the nominal B = 0.5 m differs from the true ICRs: the adapted filter is far better
    assert idd["median"] > 0.05
    assert ekf["median"] < 0.2 * idd["median"]


def test_evaluate_horizon_and_out(
    log_path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out_dir = tmp_path / "elsewhere" / "deeper"
    code, out, err = run_main(
        capsys, "evaluate", "--wheels", log_path, "--horizon", "1", "--out", out_dir
    )
    assert code == 0, err
    words = out.split()  # written: the JSON, then its plots
    assert words[words.index("written:") + 1] == str(out_dir / "evaluation.json")
    result = json.loads((out_dir / "evaluation.json").read_text(encoding="utf-8"))
    assert result["horizon_m"] == 1.0
    assert result["run"] is None
    assert list(result["models"]) == ["idd (B=0.5 m)"]
    assert out.splitlines()[0].startswith(f"{result['windows']} windows of 1 m on ")


def test_evaluate_true_icr_params_give_zero_error(
    log_path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run_dir = tmp_path / "run"
    assert run_main(capsys, "run", "--wheels", log_path, "--out", run_dir)[0] == 0
    true_params = write(
        tmp_path / "true_icr.yaml",
        "format_version: 1\nmodel: icr\nparams: {y_l: %r, y_r: %r, x_icr: %r}\n"
        % (TRUE_ICR["y_l"], TRUE_ICR["y_r"], TRUE_ICR["x_icr"]),
    )
    wrong_params = write(
        tmp_path / "wrong_icr.yaml",
        "format_version: 1\nmodel: icr\nparams: {y_l: 0.3, y_r: -0.3, x_icr: 0.0}\n",
    )

    code, out, err = run_main(
        capsys,
        "evaluate",
        "--run",
        run_dir,
        "--wheels",
        log_path,
        "--params",
        true_params,
        wrong_params,
    )

    assert code == 0, err
    result = json.loads((run_dir / "evaluation.json").read_text(encoding="utf-8"))
    names = ["idd (B=0.5 m)", "ekf (online)", "icr (true_icr.yaml)", "icr (wrong_icr.yaml)"]
    assert list(result["models"]) == names
    assert list(_table(out)) == names
    true = result["models"]["icr (true_icr.yaml)"]
    assert true["translation_m_per_m"]["median"] < 1e-6
    assert true["translation_m_per_m"]["q75"] < 1e-6
    assert true["rotation_deg_per_m"]["median"] < 1e-4
    assert true["ate_dead_reckoning"]["rmse_m"] < 1e-6
    assert _table(out)["icr (true_icr.yaml)"].split()[2] == "0.0000"
    wrong = result["models"]["icr (wrong_icr.yaml)"]["translation_m_per_m"]["median"]
    assert wrong > 0.01
    assert not math.isnan(wrong)
