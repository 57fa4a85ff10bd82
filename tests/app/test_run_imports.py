"""What a wheel-only run loads: nothing of the camera, the classifier or the plots.

A short wheel-only ``terrain-odom run --no-plots`` (a fresh process) must
not import scikit-learn, ``scipy.stats``, filterpy (the reference EKF),
OpenCV or matplotlib, and under :data:`~terrain_odom.estimation._kernels.PURE_CALLS`
kernel calls not numba either: each costs start-up time (issue 15).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

NOT_LOADED = ("sklearn", "scipy.stats", "filterpy", "cv2", "matplotlib", "numba")

SCRIPT = """
import sys
from terrain_odom.cli.main import main
code = main(["run", "--wheels", sys.argv[1], "--out", sys.argv[2], "--no-plots"])
print(code, *sorted({m.split(".")[0] if m != "scipy.stats" else m for m in sys.modules}))
"""


def test_a_short_wheel_only_run_loads_none_of_the_heavy_modules(tmp_path: Path) -> None:
    rows = (Path(__file__).resolve().parents[2] / "examples" / "demo_log.csv").read_text()
    log = tmp_path / "short.csv"
    log.write_text("".join(rows.splitlines(keepends=True)[:201]))  # header + 200 rows
    done = subprocess.run(
        [sys.executable, "-c", SCRIPT, str(log), str(tmp_path / "out")],
        capture_output=True,
        text=True,
        check=True,
    )
    code, *modules = done.stdout.splitlines()[-1].split()
    assert code == "0"
    assert "numpy" in modules and "terrain_odom" in modules  # the check sees imports
    assert [m for m in NOT_LOADED if m in modules] == []
    assert (tmp_path / "out" / "trajectory.tum").is_file()
