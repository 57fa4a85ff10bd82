"""Camera frame lists: which image was taken when.

A frame folder holds the images and, optionally, ``frames.csv`` with the
columns ``t`` (time, s, the wheel log's clock) and ``file`` (image path
relative to the folder, within it: an absolute path or ``..`` is refused). Without ``frames.csv``, every image file name (less
its suffix) must be its time in seconds, e.g. ``12.340.png``.

Examples
--------
>>> import tempfile, pathlib
>>> folder = pathlib.Path(tempfile.mkdtemp())
>>> _ = (folder / "frames.csv").write_text("t,file\\n0.5,b.png\\n0.0,a.png\\n")
>>> frames = read_frames(folder)
>>> frames.t.tolist(), [p.name for p in frames.files]
([0.0, 0.5], ['a.png', 'b.png'])
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path, PurePath

import numpy as np

from terrain_odom.errors import InputFileError
from terrain_odom.io._csv import read_csv, shown
from terrain_odom.io.images import IMAGE_SUFFIXES

__all__ = ["FrameList", "read_frames", "FRAMES_CSV", "IMAGE_SUFFIXES"]

FRAMES_CSV = "frames.csv"
"""Name of the optional frame index in a frame folder."""


@dataclass(frozen=True)
class FrameList:
    """Frames in time order.

    Attributes
    ----------
    t : ndarray, shape (N,)
        Frame times, s, non-decreasing.
    files : list of Path, shape (N,)
        Image file of each frame (may not exist: checked when read).
    source : str
        Where the list came from (``frames.csv`` or the folder), for messages.
    """

    t: np.ndarray
    files: list[Path]
    source: str

    def __len__(self) -> int:
        return len(self.files)


def _time(cell: str) -> float:
    value = float(cell)
    if not math.isfinite(value):
        raise ValueError(cell)
    return value


def read_frames(images: str | Path) -> FrameList:
    """Read the frame list of a folder (``frames.csv``, else timestamped file names).

    Raises
    ------
    InputFileError
        The folder does not exist; ``frames.csv`` is malformed (the message
        names the file, line and column); without it, the folder has no image
        or an image name is not a time in seconds.
    """
    root = Path(images)
    if not root.is_dir():
        raise InputFileError(f"{root}: --images must be a folder of camera frames")
    index = root / FRAMES_CSV
    if index.is_file():
        table = read_csv(index)
        table.require_columns("t", "file", reason="frame time and image file")
        t = table.convert(
            "t", _time, np.float64, lambda c: f"{shown(c)} is not a finite time in seconds"
        )
        names = [cell.strip() for cell in table.cells("file")]
        for row, name in enumerate(names):
            if not name:
                raise table.error("empty image file name", row=row, column="file")
            if PurePath(name).is_absolute() or ".." in PurePath(name).parts:
                raise table.error(
                    f"{shown(name)} lies outside the frames' folder; list each image by its "
                    "path within the folder",
                    row=row,
                    column="file",
                )
        order = np.argsort(t, kind="stable")
        return FrameList(t[order], [root / names[i] for i in order], str(index))
    files = sorted(p for p in root.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES)
    if not files:
        raise InputFileError(f"{root}: no {FRAMES_CSV} and no image files in the folder")
    times = []
    for path in files:
        try:
            times.append(_time(path.stem))
        except ValueError:
            raise InputFileError(
                f"{path}: without {FRAMES_CSV}, image names must be their time in seconds "
                f"(e.g. 12.340{path.suffix}); add {root / FRAMES_CSV} with columns t,file"
            ) from None
    t = np.asarray(times, dtype=np.float64)
    order = np.argsort(t, kind="stable")
    return FrameList(t[order], [files[i] for i in order], str(root))
