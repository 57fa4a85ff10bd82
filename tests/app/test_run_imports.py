"""What a wheel-only run loads: nothing of the camera, the classifier, the bags or pyplot.

A short wheel-only ``terrain-odom run --no-plots`` (a fresh process) must
not import scikit-learn, ``scipy.stats``, filterpy (the reference EKF),
OpenCV, ``rosbags`` or matplotlib, and under
:data:`~terrain_odom.estimation._kernel_switch.PURE_CALLS` kernel calls not numba
either: each costs start-up time (issue 15). With its plots, the run loads
matplotlib's figure and Agg canvas, never ``pyplot``.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

NOT_LOADED = ("sklearn", "scipy.stats", "filterpy", "cv2", "matplotlib", "numba", "rosbags")

SCRIPT = """
import sys
from terrain_odom.cli.main import main
code = main(["run", "--wheels", sys.argv[1], "--out", sys.argv[2], *sys.argv[3:]])
print(code, *sorted(sys.modules))
"""


@pytest.mark.parametrize("options", [["--no-plots"], []], ids=["no-plots", "plots"])
def test_a_short_wheel_only_run_loads_none_of_the_heavy_modules(
    tmp_path: Path, options: list[str]
) -> None:
    rows = (Path(__file__).resolve().parents[2] / "examples" / "demo_log.csv").read_text()
    log = tmp_path / "short.csv"
    log.write_text("".join(rows.splitlines(keepends=True)[:201]))  # header + 200 rows
    done = subprocess.run(
        [sys.executable, "-c", SCRIPT, str(log), str(tmp_path / "out"), *options],
        capture_output=True,
        text=True,
        check=True,
    )
    code, *modules = done.stdout.splitlines()[-1].split()
    assert code == "0"
    assert "numpy" in modules and "terrain_odom" in modules  # the check sees imports
    plots = not options
    assert [m for m in NOT_LOADED if m in modules] == (["matplotlib"] if plots else [])
    assert ("matplotlib.figure" in modules) is plots and "matplotlib.pyplot" not in modules
    assert (tmp_path / "out" / "trajectory.tum").is_file()
