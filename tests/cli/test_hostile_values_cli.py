"""Issue 24: values that used to end in a traceback or in silence, each one line and exit 2."""

from __future__ import annotations

from pathlib import Path

import pytest

from terrain_odom.cli.main import main


def _one_line(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("terrain-odom: error: "), err
    return err


@pytest.mark.parametrize("duration", ["1e12", "1e300", "360000"])
def test_simulate_duration_is_bounded_by_memory(
    duration: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    err = _one_line(["simulate", "--duration", duration, "--out", str(tmp_path / "s")], capsys)
    assert "a simulation holds in memory: at most 27.8 h" in err
    assert not (tmp_path / "s").exists()


def test_simulate_longer_than_the_map_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["simulate", "--duration", "600", "--no-frames", "--no-patches"]
    err = _one_line([*argv, "--out", str(tmp_path / "s")], capsys)
    assert "the robot leaves the scenario's map at t = 78.48 s" in err
    assert not (tmp_path / "s").exists()


PARAMS = """\
format_version: 2
model: icr
track_width: 0.5
wheel_radius: 0.1
pose_delay: 0.0
horizon: 2m
sigma: null
bounds:
  y_l: [0.05, 50.0]
  y_r: [-50.0, -0.05]
  x_icr: [-50.0, 50.0]
params: {y_l: Y_L, y_r: Y_R, x_icr: 0.08}
AT_BOUNDS"""


@pytest.mark.parametrize(
    ("y_l", "y_r", "at_bounds", "expected"),
    [
        ("-0.5", "0.5", "", "params: the ICRs need y_l > 0 > y_r, got y_l=-0.5, y_r=0.5"),
        ("0.5", "0.5", "", "params: the ICRs need y_l > 0 > y_r, got y_l=0.5, y_r=0.5"),
        ("60.0", "-0.5", "", "params.y_l: 60 lies outside its bounds [0.05, 50]"),
        ("0.5", "-50.5", "", "params.y_r: -50.5 lies outside its bounds [-50, -0.05]"),
        ("0.5", "-0.5", "at_bounds: [y_l]", "at_bounds: says ['y_l'], but the parameters at a "),
        ("0.05", "-0.5", "", "at_bounds: says [], but the parameters at a bound are ['y_l']"),
    ],
)
@pytest.mark.parametrize("subcommand", ["evaluate", "run"])
def test_parameter_files_contradicting_themselves_are_one_line(
    subcommand: str,
    y_l: str,
    y_r: str,
    at_bounds: str,
    expected: str,
    examples_dir: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    params = tmp_path / "params_icr.yaml"
    text = PARAMS.replace("Y_L", y_l).replace("Y_R", y_r).replace("AT_BOUNDS", at_bounds)
    params.write_text(text + "\n")
    log = str(examples_dir / "demo_log.csv")
    option = "--params" if subcommand == "evaluate" else "--priors"
    argv = [subcommand, "--wheels", log, option, str(params)]
    if subcommand == "run":
        argv += ["--out", str(tmp_path / "run")]
    err = _one_line(argv, capsys)
    assert f"{params}: {expected}" in err
    assert params.read_text() == text + "\n"
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("gap", [1e6, 61.0])
def test_a_long_gap_within_a_segment_is_one_line(
    gap: float, examples_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Dead reckoning across a gap of 1e6 s is no estimate: the log must mark a new segment."""
    lines = (examples_dir / "demo_log.csv").read_text().splitlines()
    late = [f"{float(row.split(',')[0]) + gap:.2f},{row.split(',', 1)[1]}" for row in lines[901:]]
    log = tmp_path / "gap.csv"
    log.write_text("\n".join([*lines[:901], *late]) + "\n")
    before = log.read_bytes()
    err = _one_line(["run", "--wheels", str(log), "--out", str(tmp_path / "run")], capsys)
    assert (
        f"{log}, line 902, column 't': {gap + 0.05:.6g} s without wheel speeds within segment 0"
        in err
    )
    assert "Start a new segment there" in err
    assert log.read_bytes() == before
    # marked as a new segment, the same rows run
    segmented = tmp_path / "segmented.csv"
    rows = [f"{row},{0 if k < 900 else 1}" for k, row in enumerate([*lines[1:901], *late])]
    segmented.write_text("\n".join([lines[0] + ",segment", *rows]) + "\n")
    argv = ["run", "--wheels", str(segmented), "--out", str(tmp_path / "ok"), "--no-plots"]
    assert main([*argv, "--no-checks"]) == 0


@pytest.mark.parametrize("name", ["bad\nname.csv", "bad\x1b[31mred.csv", "tab\there.csv"])
def test_a_file_name_with_control_characters_is_printed_escaped_on_one_line(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = tmp_path / name
    log.write_text("t,v_l,v_r\n0,x,1\n")
    err = _one_line(["run", "--wheels", str(log), "--out", str(tmp_path / "out")], capsys)
    assert "\x1b" not in err and "\t" not in err
    assert repr(name)[1:-1] in err  # \n, \x1b, \t as escapes


def test_an_undecodable_file_name_is_printed_escaped(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = tmp_path / b"caf\xe9.csv".decode("utf-8", "surrogateescape")  # Latin-1 bytes
    err = _one_line(["run", "--wheels", str(log), "--out", str(tmp_path / "out")], capsys)
    assert "caf\\xe9.csv" in err
