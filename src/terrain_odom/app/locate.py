"""Where an ``out`` folder's file goes, and which file an input folder holds.

The command line's grammar: ``--out`` is a folder the subcommand writes its
file into under a fixed name (``params_<model>.yaml``, ``classifier.npz``,
``evaluation.json``); a name with the file's own suffix is the old form and
names the file itself. Inputs written that way (``run --classifier``,
``run --priors``, ``evaluate --params``) may be given as the file or as a
folder holding exactly one such file.
"""

from __future__ import annotations

import contextlib
import errno
from collections.abc import Sequence
from pathlib import Path

from terrain_odom.errors import InputFileError
from terrain_odom.io.folder import replacing

__all__ = [
    "names_a_file",
    "output_file",
    "output_folder",
    "check_out",
    "create_folder",
    "writing_into",
    "find_input",
]


def names_a_file(out: str | Path, suffixes: Sequence[str]) -> bool:
    """Return whether ``out`` names a file: it ends in one of ``suffixes`` and is no folder.

    Examples
    --------
    >>> names_a_file("fit/grass.yaml", (".yaml", ".yml")), names_a_file("fit/grass", (".yaml",))
    (True, False)
    """
    path = Path(out)
    return path.suffix.lower() in suffixes and not path.is_dir()


def output_file(out: str | Path, name: str, suffixes: Sequence[str]) -> Path:
    """Return the file to write for ``out``: ``out`` itself if it names a file, else ``out/name``.

    Examples
    --------
    >>> str(output_file("fit", "params_idd.yaml", (".yaml",)))
    'fit/params_idd.yaml'
    >>> str(output_file("grass.yaml", "params_idd.yaml", (".yaml",)))
    'grass.yaml'
    """
    return Path(out) if names_a_file(out, suffixes) else Path(out) / name


def output_folder(out: str | Path) -> Path:
    """Return the output folder ``out`` (not created); refuse a file of that name.

    Raises
    ------
    InputFileError
        A file named ``out`` exists.
    """
    path = Path(out)
    if path.exists() and not path.is_dir():
        raise InputFileError(f"{path}: --out must be a directory, but a file of that name exists")
    return path


def check_out(out: str | Path, suffixes: Sequence[str]) -> None:
    """Raise unless ``out`` can be written: a file's folder exists, a folder is no file.

    Raises
    ------
    FileNotFoundError
        ``out`` names a file in a folder that does not exist (naming the file).
    NotADirectoryError
        ``out`` is a folder to create, but a file of that name exists.
    """
    path = Path(out)
    if names_a_file(path, suffixes):
        if not path.parent.is_dir():
            raise FileNotFoundError(errno.ENOENT, "its folder does not exist", str(path))
    elif path.exists() and not path.is_dir():
        raise NotADirectoryError(errno.ENOTDIR, "is a file, not an output folder", str(path))


def create_folder(out: str | Path, suffixes: Sequence[str]) -> None:
    """Create the folder ``out`` (and its parents) unless it names a file."""
    if not names_a_file(out, suffixes):
        Path(out).mkdir(parents=True, exist_ok=True)


def writing_into(
    out: str | Path | None,
    target: Path,
    command: str,
    names: Sequence[str],
    suffixes: Sequence[str],
) -> contextlib.AbstractContextManager[object]:
    """Lock ``target``'s folder while ``command`` writes ``names`` into it.

    :func:`~terrain_odom.io.folder.replacing`: ``command``'s own previous
    files among ``names`` are replaced, its other files kept (``fit`` of
    another model), and a file among ``names`` it did not write (another
    command's, edited since) is refused. The old form, ``out`` naming the
    file itself, is written as it is.
    """
    if out is not None and names_a_file(out, suffixes):
        return contextlib.nullcontext()
    return replacing(target.parent, command, names, all_previous=False)


def find_input(path: str | Path, pattern: str, kind: str) -> Path:
    """Return the file an input names: ``path`` itself, or the one file matching ``pattern`` in it.

    Parameters
    ----------
    path : str or Path
        A file, or a folder (e.g. the ``--out`` folder of ``fit`` or ``train``).
    pattern : str
        Glob pattern of the file in a folder, e.g. ``"params_*.yaml"``.
    kind : str
        What the file is, for messages.

    Raises
    ------
    InputFileError
        ``path`` is a folder with no file matching ``pattern``, or with
        several (listed).
    """
    folder = Path(path)
    if not folder.is_dir():
        return folder
    found = sorted(p for p in folder.glob(pattern) if p.is_file())
    if len(found) == 1:
        return found[0]
    if not found:
        raise InputFileError(f"{folder}: no {kind} ({pattern}) in this folder")
    names = ", ".join(p.name for p in found)
    raise InputFileError(
        f"{folder}: {len(found)} {kind}s ({names}) in this folder; name one of them"
    )
