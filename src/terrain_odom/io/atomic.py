"""Atomic file output: a reader never sees a half-written file."""

from __future__ import annotations

import contextlib
import errno
import os
import secrets
from collections.abc import Callable
from pathlib import Path
from types import TracebackType
from typing import BinaryIO, TypeVar

from terrain_odom.errors import TerrainOdomError

__all__ = ["AtomicFile", "OutputFileError", "write_atomic", "write_text_atomic"]


class OutputFileError(TerrainOdomError, OSError):
    """A file cannot be written; ``filename`` is the target (never a temporary file)."""

    def __str__(self) -> str:
        if self.errno in (errno.ENOSPC, errno.EDQUOT):
            return f"{self.filename}: cannot write: no space left on the device"
        return f"{self.filename}: cannot write ({self.strerror})"


_Atomic = TypeVar("_Atomic", bound="AtomicFile")


class AtomicFile:
    """A binary file written to a temporary file that replaces ``path`` when closed cleanly.

    A context manager: inside, write to :attr:`handle`; on a clean exit the
    bytes are synced to disk and the temporary file (a new file in the same
    folder, with the usual permissions, i.e. subject to the umask) replaces
    ``path``; on any exception it is removed and an existing ``path`` is
    left untouched. So a file can be streamed block by block and readers
    still never see a partial one.

    Raises
    ------
    FileNotFoundError
        If the folder of ``path`` does not exist (naming that folder and
        ``path``).
    OutputFileError
        On any other operating-system error (read-only folder, full disk,
        ``path`` a folder, ...), naming ``path``.
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)
        if not self.path.parent.is_dir():
            raise FileNotFoundError(
                errno.ENOENT,
                f"directory does not exist, cannot write {self.path}",
                str(self.path.parent),
            )
        self._temporary = self.path.with_name(f".{self.path.name}.{secrets.token_hex(4)}.tmp")
        try:
            self.handle: BinaryIO = open(self._temporary, "xb")  # noqa: SIM115 - closed in __exit__
        except OSError as exc:
            raise OutputFileError(exc.errno, exc.strerror, str(self.path)) from exc

    def write_bytes(self, data: bytes) -> None:
        """Write ``data`` to the temporary file; ``OutputFileError`` naming ``path`` on failure."""
        try:
            self.handle.write(data)
        except OSError as exc:
            raise OutputFileError(exc.errno, exc.strerror, str(self.path)) from None

    def discard(self) -> None:
        """Close and remove the temporary file, leaving ``path`` as it was; exiting then does nothing.

        Bytes that cannot be written any more (a full disk) are dropped with it.
        """
        with contextlib.suppress(OSError):
            self.handle.close()  # closed even when its last flush fails
        self._temporary.unlink(missing_ok=True)

    def __enter__(self: _Atomic) -> _Atomic:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        if self.handle.closed:  # discarded
            return
        if exc_type is not None:  # the error at hand says more than a failing close
            self.discard()
            return
        try:
            with self.handle:
                self.handle.flush()
                os.fsync(self.handle.fileno())
            os.replace(self._temporary, self.path)
        except OSError as error:
            raise OutputFileError(error.errno, error.strerror, str(self.path)) from None
        finally:
            self._temporary.unlink(missing_ok=True)


def write_atomic(path: str | os.PathLike[str], write: Callable[[BinaryIO], object]) -> None:
    """Write a file through ``write(handle)`` atomically (see :class:`AtomicFile`).

    Raises
    ------
    FileNotFoundError, OutputFileError
        As :class:`AtomicFile`; an ``OSError`` raised by ``write`` becomes
        an ``OutputFileError`` naming ``path``.
    """
    with AtomicFile(path) as file:
        try:
            write(file.handle)
        except OutputFileError:
            raise
        except OSError as exc:
            raise OutputFileError(exc.errno, exc.strerror, str(path)) from None


def write_text_atomic(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` as UTF-8 atomically (see :func:`write_atomic`)."""
    data = text.encode("utf-8")
    write_atomic(path, lambda handle: handle.write(data))
