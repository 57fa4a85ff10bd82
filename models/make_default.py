"""Regenerate ``src/terrain_odom/models/default.npz``, the default classifier of ``terrain-odom run``.

The model ships as package data (found through ``importlib.resources``,
:func:`terrain_odom.io.classifier_file.default_model_path`), so that an
installed package runs the quick start from any folder.

Trained on the labelled patches (grass, gravel, brick; 40 each) of a
simulated ``chen2023`` run with seed 1, drawn from map areas that run does
not drive over, with the default classifier settings but for tiles of about
32 px a side (``--tile-size 32``: a region's classification time is then
proportional to its area, which is what the region of interest saves). The
quick-start sample (``sample_images/chen2023``) is seed 0, so the model is
not trained on it.
From the repository root::

    python models/make_default.py

which runs exactly::

    terrain-odom simulate --out TMP --scenario chen2023 --seed 1 --duration 48 --no-frames
    terrain-odom train --images TMP/patches --out TMP/model --tile-size 32

and moves ``TMP/model/classifier.npz`` to ``src/terrain_odom/models/default.npz``.
"""

from __future__ import annotations

import shutil
import sys
import tempfile
from pathlib import Path

from terrain_odom.cli.main import main as cli

HERE = Path(__file__).resolve().parent
MODEL = HERE.parent / "src" / "terrain_odom" / "models" / "default.npz"
SEED = 1
TILE_SIZE = 32  # px


def make(out: str | Path = MODEL) -> int:
    """Simulate the training patches and train the model into ``out``; return the exit code."""
    with tempfile.TemporaryDirectory() as tmp:
        args = ["simulate", "--out", tmp, "--scenario", "chen2023", "--seed", str(SEED)]
        code = cli([*args, "--duration", "48", "--no-frames"])
        if code == 0:
            patches, model = str(Path(tmp) / "patches"), Path(tmp) / "model"
            train = ["train", "--images", patches, "--out", str(model)]
            code = cli([*train, "--tile-size", str(TILE_SIZE)])
        if code == 0:
            shutil.move(model / "classifier.npz", out)
    return code


if __name__ == "__main__":
    sys.exit(make(sys.argv[1] if len(sys.argv) > 1 else MODEL))
