"""``terrain-odom adopt``: record a folder's files as written by a command.

A folder written before folders had a manifest (``.terrain-odom.json``,
:mod:`terrain_odom.io.folder`), or files put there by hand, are refused by
every command that would replace them. Adopting them is the explicit way to
say which command wrote them: that command may then replace them
(``--overwrite``), and an edit made after the adoption is still noticed.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from terrain_odom.errors import InputFileError
from terrain_odom.io.folder import writing

__all__ = ["WRITERS", "Adoption", "adopt"]

WRITERS = (
    "run",
    "import",
    "simulate",
    "degrade",
    "calibrate",
    "fit",
    "evaluate",
    "train",
    "compare",
    "report accuracy",
    "patches",
)
"""The commands that write output folders, as the manifest names them."""


@dataclass(frozen=True)
class Adoption:
    """What :func:`adopt` recorded.

    Attributes
    ----------
    folder : Path
        The folder.
    command : str
        The command its files are now recorded for.
    adopted : tuple of str
        Files recorded now (relative to the folder).
    kept : tuple of str
        Files the manifest recorded already, left as they were.
    """

    folder: Path
    command: str
    adopted: tuple[str, ...]
    kept: tuple[str, ...]


def adopt(folder: str | Path, command: str, files: Sequence[str] = ()) -> Adoption:
    """Record ``files`` of ``folder`` (default: all of them) as written by ``command``.

    Raises
    ------
    InputFileError
        ``folder`` is no folder (it is never created), a file is not within
        it, another command holds it, or ``command`` writes no folder.
    """
    path = Path(folder)
    if command not in WRITERS:
        raise InputFileError(f"--by {command}: writes no folder; one of {', '.join(WRITERS)}")
    if not path.is_dir():
        raise InputFileError(f"{path}: no such folder")
    with writing(path, command) as opened:
        adopted, kept = opened.adopt(list(files) or None)
    return Adoption(path, command, tuple(adopted), tuple(kept))
