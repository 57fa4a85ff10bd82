"""``run --no-plots``: the same run without drawing its plots."""

from __future__ import annotations

from pathlib import Path

from terrain_odom.cli.main import main


def test_no_plots_skips_only_the_plots(tmp_path: Path, examples_dir: Path, capsys) -> None:
    """No PNG is drawn or named; the trajectory is byte-identical to a run with plots."""
    log = str(examples_dir / "demo_log.csv")
    with_plots, without = tmp_path / "plots", tmp_path / "none"
    assert main(["run", "--wheels", log, "--out", str(with_plots)]) == 0
    assert "plots:" in capsys.readouterr().out
    assert main(["run", "--wheels", log, "--out", str(without), "--no-plots"]) == 0
    printed = capsys.readouterr().out
    assert "plots:" not in printed and "trajectory:" in printed
    assert list(with_plots.rglob("*.png")) and not list(without.rglob("*.png"))
    for name in ("trajectory.csv", "trajectory.tum"):
        assert (without / name).read_bytes() == (with_plots / name).read_bytes()
