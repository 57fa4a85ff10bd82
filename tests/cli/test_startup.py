"""Start-up of ``terrain-odom run`` (issue 15): the libraries a wheel-only run loads.

A fresh process, as a user's: a run on a CSV log loads no scikit-learn,
``scipy.stats``, numba (a short log), filterpy or ``rosbags``; with
``--no-plots`` no matplotlib either, and with plots no ``pyplot``.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

SRC = Path(__file__).resolve().parents[2] / "src"

NEVER = ("sklearn", "scipy.stats", "numba", "filterpy", "rosbags", "matplotlib.pyplot")


def _loaded_by_runs(log: Path, out: Path, *runs: list[str]) -> list[list[str]]:
    """Run ``terrain-odom run`` with each option list in one fresh process; modules after each."""
    code = (
        "import sys\nfrom terrain_odom.cli.main import main\n"
        f"for options in {list(runs)!r}:\n"
        f"    assert main(['run', '--wheels', {str(log)!r}, '--out', {str(out)!r}, '--overwrite',"
        " *options]) == 0\n"
        "    print('@@', ' '.join(sorted(sys.modules)))\n"
    )
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                          timeout=120, check=False)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    return [line.split()[1:] for line in proc.stdout.splitlines() if line.startswith("@@")]


def _heavy(modules: list[str]) -> list[str]:
    return [m for m in modules if m in NEVER or m.split(".")[0] in NEVER]


def test_a_short_wheel_only_run_loads_no_heavy_library(examples_dir: Path, tmp_path: Path) -> None:
    """200 rows (the filter's kernels stay Python: no numba), with and without plots."""
    short = tmp_path / "short.csv"
    rows = (examples_dir / "demo_log.csv").read_text().splitlines(keepends=True)[:201]
    short.write_text("".join(rows))
    bare, plotted = _loaded_by_runs(short, tmp_path / "out", ["--no-plots"], [])
    assert _heavy(bare) == [] and not [m for m in bare if m.startswith("matplotlib")]
    assert _heavy(plotted) == [] and "matplotlib.figure" in plotted
