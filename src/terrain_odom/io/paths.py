"""Output paths that never destroy an input.

Every command of :mod:`terrain_odom.app` calls :func:`check_outputs` with the
files it reads and the files it will write, before it reads or writes
anything, so that the Python API is protected as well as the command line.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path

from terrain_odom.errors import InputFileError

__all__ = ["check_outputs"]

PathLike = str | os.PathLike[str]


def check_outputs(inputs: Iterable[PathLike | None], outputs: Iterable[PathLike]) -> None:
    """Refuse to write any of ``outputs`` over one of ``inputs``.

    An output clashes with an input when both are the same file
    (:func:`os.path.samefile`: also through a symbolic or hard link); an
    output that does not exist yet cannot be an input.

    Parameters
    ----------
    inputs : iterable of str or Path or None
        Files read (``None`` entries, options not given, and files that do
        not exist are skipped).
    outputs : iterable of str or Path
        Files to be written.

    Raises
    ------
    InputFileError
        Naming the output and the input it would overwrite.
    """
    given = [Path(p) for p in inputs if p is not None]
    for out in map(Path, outputs):
        if not out.exists():
            continue
        for source in given:
            if source.exists() and os.path.samefile(out, source):
                raise InputFileError(
                    f"{out}: refusing to overwrite the input {source}; "
                    "choose an output path that is not an input"
                )
