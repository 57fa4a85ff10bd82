"""Atomic file output: a reader never sees a half-written file."""

from __future__ import annotations

import errno
import os
import secrets
from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO

from terrain_odom.errors import TerrainOdomError

__all__ = ["OutputFileError", "write_atomic", "write_text_atomic"]


class OutputFileError(TerrainOdomError, OSError):
    """A file cannot be written; ``filename`` is the target (never a temporary file)."""

    def __str__(self) -> str:
        return f"{self.filename}: cannot write ({self.strerror})"


def write_atomic(path: str | os.PathLike[str], write: Callable[[BinaryIO], object]) -> None:
    """Write a file through ``write(handle)`` atomically.

    The bytes go to a new temporary file in the same folder (created with the
    usual permissions, i.e. subject to the umask), synced to disk, which then
    replaces ``path``; on any error the temporary file is removed and an
    existing ``path`` is left untouched.

    Raises
    ------
    FileNotFoundError
        If the folder of ``path`` does not exist (naming that folder and
        ``path``).
    OutputFileError
        On any other operating-system error (read-only folder, full disk,
        ``path`` a folder, ...), naming ``path``.
    """
    path = Path(path)
    if not path.parent.is_dir():
        raise FileNotFoundError(
            errno.ENOENT, f"directory does not exist, cannot write {path}", str(path.parent)
        )
    temporary = path.with_name(f".{path.name}.{secrets.token_hex(4)}.tmp")
    try:
        with open(temporary, "xb") as handle:
            write(handle)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(temporary, path)
    except OSError as exc:
        raise OutputFileError(exc.errno, exc.strerror, str(path)) from exc
    finally:
        temporary.unlink(missing_ok=True)


def write_text_atomic(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` as UTF-8 atomically (see :func:`write_atomic`)."""
    data = text.encode("utf-8")
    write_atomic(path, lambda handle: handle.write(data))
