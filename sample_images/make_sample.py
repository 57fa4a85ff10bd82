"""Regenerate ``sample_images/chen2023``, the simulated run of the README quick start.

48 s of the ``chen2023`` scenario (grass, then gravel for ~20 s, then grass)
with seed 0, camera frames at 2 Hz as JPEG (quality 90), no training patches.
From the repository root::

    python sample_images/make_sample.py

which runs exactly::

    terrain-odom simulate --out sample_images/chen2023 --scenario chen2023 --seed 0 \\
        --duration 48 --frame-rate 2 --frame-format jpg --no-patches

The default classifier (``models/default.npz``) is trained on another seed's
patches (``models/make_default.py``), not on this run.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

from terrain_odom.cli.main import main as cli

HERE = Path(__file__).resolve().parent
SAMPLE = HERE / "chen2023"
SEED = 0
ARGS = (
    "--scenario",
    "chen2023",
    "--seed",
    str(SEED),
    "--duration",
    "48",
    "--frame-rate",
    "2",
    "--frame-format",
    "jpg",
    "--no-patches",
)


def make(out: str | Path = SAMPLE) -> int:
    """Write the sample run to ``out`` (its old frames removed first); return the exit code."""
    out = Path(out)
    shutil.rmtree(out / "frames", ignore_errors=True)
    return cli(["simulate", "--out", str(out), *ARGS])


if __name__ == "__main__":
    sys.exit(make(sys.argv[1] if len(sys.argv) > 1 else SAMPLE))
