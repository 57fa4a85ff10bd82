"""Output folders that know what wrote them, locked while a command writes them.

A writing command opens its ``--out`` folder with :func:`writing`:

- the folder is created (with its parents) and **locked** for the life of
  the command (``fcntl.flock`` on the folder itself, exclusive): a second
  command on the same folder is refused with one line naming the holder
  (command, process, since when); the lock goes with the process, so a
  killed command never leaves a stale lock;
- its **manifest**, ``.terrain-odom.json``, records which command wrote
  which file (path relative to the folder, SHA-256 of its content) in this
  folder's current life (a folder deleted and made again starts afresh);
- :meth:`OutputFolder.prepare` refuses, in one line, to replace a file the
  command did not write (a file written by another command, a file edited
  since, a file the manifest does not know), then, where asked to
  overwrite, removes exactly the command's own previous files (so old and
  new never mix) and keeps every other file;
- :meth:`OutputFolder.adopt` records files already there as the command's
  (``terrain-odom adopt``: a folder written before folders had a manifest);
- on leaving, the files written are recorded with their hashes (also when
  the command stops with an error or a signal); a file being written when
  the process was killed stays recorded as the command's (``sha256`` null),
  so ``--overwrite`` can replace it.

:func:`holder` says whether a folder is locked now, and by whom.
"""

from __future__ import annotations

import contextlib
import datetime
import errno
import fcntl
import glob
import hashlib
import json
import os
import shlex
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from typing import Any

from terrain_odom.errors import InputFileError
from terrain_odom.io.atomic import OutputFileError, write_atomic, write_text_atomic

__all__ = [
    "MANIFEST",
    "FolderInUseError",
    "Holder",
    "OutputFolder",
    "create_folder",
    "holder",
    "replacing",
    "writing",
    "writing_if",
]

MANIFEST = ".terrain-odom.json"
"""The manifest of an output folder."""
_FORMAT = 1


class FolderInUseError(InputFileError):
    """Another command holds the folder's lock."""


@dataclass(frozen=True)
class Holder:
    """The command holding a folder's lock.

    Attributes
    ----------
    command : str
        Subcommand (``run``, ``import`` ...).
    pid : int or None
        Its process id (None if the manifest does not say).
    since : str
        Local time it took the lock, ISO 8601 (empty if unknown).
    """

    command: str
    pid: int | None
    since: str

    def describe(self) -> str:
        """Return e.g. ``terrain-odom run (process 1234, since 2026-11-27 15:20:01)``."""
        pid = "an unknown process" if self.pid is None else f"process {self.pid}"
        since = f", since {self.since}" if self.since else ""
        return f"terrain-odom {self.command} ({pid}{since})"


def create_folder(path: str | Path) -> Path:
    """Create the folder ``path`` with its parents; refuse a file of that name.

    Raises
    ------
    InputFileError
        A file (not a folder) of that name exists.
    OutputFileError
        The folder cannot be created (read-only file system, name too long,
        no permission ...), naming it.
    """
    folder = Path(path)
    try:
        if folder.exists() and not folder.is_dir():
            raise InputFileError(
                f"{folder}: --out must be a directory, but a file of that name exists"
            )
        folder.mkdir(parents=True, exist_ok=True)
    except OutputFileError:
        raise
    except OSError as exc:
        raise OutputFileError(exc.errno, exc.strerror, str(folder)) from None
    return folder


def holder(path: str | Path) -> Holder | None:
    """Return who holds the lock of the folder ``path`` now, or None if nobody does."""
    folder = Path(path)
    try:
        fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    except OSError:
        return None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:
            return _holder_of(_read_manifest(folder))
        fcntl.flock(fd, fcntl.LOCK_UN)
        return None
    finally:
        os.close(fd)


def _holder_of(manifest: dict[str, Any]) -> Holder:
    entry = manifest.get("holder")
    if not isinstance(entry, dict):
        return Holder("(unknown command)", None, "")
    pid = entry.get("pid")
    return Holder(
        str(entry.get("command", "(unknown command)")),
        pid if isinstance(pid, int) else None,
        str(entry.get("since", "")),
    )


def _read_manifest(folder: Path) -> dict[str, Any]:
    """Return the folder's manifest (empty if it has none or it is unreadable).

    Only entries naming a file within the folder are kept: a manifest naming
    ``/etc/passwd`` or ``../x`` (edited by hand) never makes a command
    remove a file elsewhere.
    """
    try:
        data = json.loads((folder / MANIFEST).read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):
        return {}
    if not isinstance(data, dict) or not isinstance(data.get("files"), dict):
        return {}
    data["files"] = {
        name: entry
        for name, entry in data["files"].items()
        if _within(name)
        and isinstance(entry, dict)
        and isinstance(entry.get("command"), str)
        and (entry.get("sha256") is None or isinstance(entry.get("sha256"), str))
    }
    return data


def _within(name: str) -> bool:
    """Whether ``name`` is a relative path inside the folder (no ``..``, not absolute)."""
    path = PurePosixPath(name)
    return bool(name) and not path.is_absolute() and ".." not in path.parts


def _read_bytes(path: Path) -> bytes | None:
    try:
        return path.read_bytes()
    except OSError:
        return None


def _restore(path: Path, data: bytes | None) -> None:
    """Put the file ``path`` back as ``data`` (None: it did not exist)."""
    if data is None:
        path.unlink(missing_ok=True)
    else:
        write_atomic(path, lambda handle: handle.write(data))


def _sha256(path: Path) -> str | None:
    """Return the SHA-256 of a regular file's content, or None if it is no regular file."""
    if not path.is_file():
        return None
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for chunk in iter(lambda: handle.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


@dataclass
class OutputFolder:
    """An output folder opened by one command with :func:`writing` (locked meanwhile).

    Attributes
    ----------
    path : Path
        The folder.
    command : str
        The command writing it.
    """

    path: Path
    command: str
    _files: dict[str, dict[str, Any]] = field(default_factory=dict)
    _claimed: list[str] = field(default_factory=list)
    _before: set[str] = field(default_factory=set)
    _holder: Holder | None = None

    def previous(self, commands: Iterable[str] | None = None) -> list[str]:
        """Return the files recorded for ``commands`` (default: this command) that exist."""
        owners = {self.command} if commands is None else set(commands)
        names = {
            name
            for name, entry in self._files.items()
            if entry.get("command") in owners and not name.endswith("/")
        }
        folders = tuple(
            name
            for name, entry in self._files.items()
            if entry.get("command") in owners and name.endswith("/")
        )
        if folders:  # being written when the process died: every file under it
            names |= {f for f in self._existing() if f.startswith(folders)}
        return sorted(name for name in names if (self.path / name).exists())

    def prepare(
        self,
        names: Iterable[str],
        *,
        overwrite: bool,
        replaces: Iterable[str] = (),
        refuse: Callable[[list[str]], str] | None = None,
        remove: bool = True,
        all_previous: bool = True,
    ) -> None:
        """Check the files this command will write; remove its previous files if ``overwrite``.

        Parameters
        ----------
        names : iterable of str
            Files the command may write, relative to the folder; a name
            ending in ``/`` stands for every file under that folder.
        overwrite : bool
            Remove the previous files of this command (and of ``replaces``):
            all of them, also those it will not write again. Without it a
            folder holding any of them is refused.
        replaces : iterable of str
            Other commands whose files count as this command's own (e.g.
            ``evaluate`` writing into a run's folder).
        refuse : callable, optional
            Given the previous files found without ``overwrite``, returns the
            refusal (default: "already holds ...; --overwrite to replace them").
        remove : bool
            False: only check, change nothing.
        all_previous : bool
            True: the command's previous files are all of its files in the
            folder (one output set per folder: ``run``, ``import``); False:
            only those among ``names`` (``fit`` of several models into one
            folder keeps the other models' files).

        Raises
        ------
        InputFileError
            One line: a file it would replace that it did not write (or that
            was edited since), or previous files without ``overwrite``.
        OutputFileError
            A previous file cannot be removed.
        """
        owners = {self.command, *replaces}
        targets = self._targets(list(names))
        previous = self.previous(owners)
        if not all_previous:
            previous = [name for name in previous if name in targets]
        for name in sorted(set(targets) | set(previous)):
            self._check_own(name, owners)
        if previous and not overwrite:
            message = refuse(previous) if refuse is not None else _already(self, previous)
            raise InputFileError(message)
        if not remove:
            return
        self._remove(previous)
        self._remove_temporaries(names)
        for name in [n for n, e in self._files.items() if n.endswith("/")]:
            if self._files[name].get("command") in owners:
                del self._files[name]  # emptied by _remove
        self._claimed = list(names)
        if any(name.endswith("/") for name in self._claimed):
            self._before = set(self._existing())
        for name in self._claimed:  # being written: the command's, whatever they hold
            if name not in self._files:
                self._files[name] = {"command": self.command, "sha256": None}
        self._save()

    def _targets(self, names: list[str]) -> list[str]:
        """Return the existing files among ``names`` (folders expanded to their files)."""
        found = []
        existing = None
        for name in names:
            if name.endswith("/"):
                existing = self._existing() if existing is None else existing
                found += [f for f in existing if f.startswith(name)]
            elif (self.path / name).exists() or (self.path / name).is_symlink():
                found.append(name)
        return found

    def _check_own(self, name: str, owners: set[str]) -> None:
        """Refuse ``name`` unless the manifest records it for ``owners``, unedited."""
        path = self.path / name
        entry = self._files.get(name) or self._pending_folder(name)
        if entry is None:
            raise InputFileError(
                f"{path}: not written by terrain-odom {self.command} in this folder (no record "
                f"in its {MANIFEST}), and {self.command} would replace it; move it away, choose "
                f"another --out, or if {self.command} wrote it before folders had a manifest: "
                f"terrain-odom adopt {shlex.quote(str(self.path))} --by {self.command.split()[0]}"
            )
        writer = entry.get("command")
        if entry.get("sha256") is not None and _sha256(path) != entry["sha256"]:
            raise InputFileError(
                f"{path}: edited since terrain-odom {writer} wrote it, and {self.command} "
                "would replace it; move it away or choose another --out"
            )
        if writer not in owners:
            raise InputFileError(
                f"{path}: written by terrain-odom {writer}, and {self.command} would replace "
                "it; choose another --out"
            )

    def _remove_temporaries(self, names: Iterable[str]) -> None:
        """Remove the temporary files of ``names`` a killed process left (``.NAME.*.tmp``)."""
        for name in names:
            if not name.endswith("/"):
                path = self.path / name
                for temporary in path.parent.glob(f".{glob.escape(path.name)}.*.tmp"):
                    with contextlib.suppress(OSError):
                        temporary.unlink()

    def _pending_folder(self, name: str) -> dict[str, Any] | None:
        """Return the entry of a folder being written (``frames/``) that holds ``name``."""
        for folder, entry in self._files.items():
            if folder.endswith("/") and name.startswith(folder):
                return entry
        return None

    def _remove(self, names: list[str]) -> None:
        """Remove ``names`` and the folders they leave empty; drop them from the manifest."""
        for name in names:
            path = self.path / name
            try:
                path.unlink(missing_ok=True)
            except OSError as exc:
                raise OutputFileError(exc.errno, exc.strerror, str(path)) from None
            self._files.pop(name, None)
            self._remove_empty_parents(path)

    def _remove_empty_parents(self, path: Path) -> None:
        """Remove the folders between ``path`` and the folder that are empty."""
        for parent in path.parents:
            if parent == self.path or not parent.is_relative_to(self.path):
                break
            with contextlib.suppress(OSError):  # not empty: kept
                parent.rmdir()

    def _existing(self) -> list[str]:
        """Return every file under the folder (relative, POSIX), but the manifest."""
        found = []
        for root, dirs, files in os.walk(self.path):
            dirs.sort()
            base = Path(root).relative_to(self.path)
            found += [(base / f).as_posix() for f in sorted(files)]
        return [f for f in found if f != MANIFEST]

    def adopt(self, names: Iterable[str] | None = None) -> tuple[list[str], list[str]]:
        """Record files already in the folder as this command's, with their content now.

        For a folder written before folders had a manifest (or by hand): the
        explicit way to let the command replace them again. Files the
        manifest records already keep their record.

        Parameters
        ----------
        names : iterable of str, optional
            Files relative to the folder (default: every file in it).

        Returns
        -------
        adopted, kept : list of str
            The files recorded now, and those already recorded (unchanged).

        Raises
        ------
        InputFileError
            A name that is no file within the folder.
        """
        existing = self._existing()
        chosen = existing if names is None else [self._inside(name) for name in names]
        adopted, kept = [], []
        for name in chosen:
            if name in self._files:
                kept.append(name)
                continue
            self._files[name] = {"command": self.command, "sha256": _sha256(self.path / name)}
            adopted.append(name)
        self._claimed += adopted  # recorded on leaving, as files written
        return adopted, kept

    def _inside(self, name: str) -> str:
        """Return ``name`` (relative to the folder, or a path into it) as the manifest names it."""
        path = Path(name)
        if path.is_absolute() or path.parts[: len(self.path.parts)] == self.path.parts:
            try:
                path = path.resolve().relative_to(self.path.resolve())
            except ValueError:
                raise InputFileError(f"{name}: not within the folder {self.path}") from None
        relative = path.as_posix()
        if not _within(relative) or not (self.path / relative).is_file():
            raise InputFileError(f"{self.path / relative}: no file within the folder {self.path}")
        if relative == MANIFEST:
            raise InputFileError(f"{self.path / relative}: the manifest itself")
        return relative

    def record(self) -> None:
        """Record the files this command wrote (claimed and existing) with their hashes."""
        claimed = [name for name in self._claimed if not name.endswith("/")]
        folders = tuple(name for name in self._claimed if name.endswith("/"))
        names = set(claimed)
        if folders:
            names |= {
                f for f in self._existing() if f.startswith(folders) and f not in self._before
            }
        for name in folders:
            self._files.pop(name, None)  # its files are recorded one by one
        for name in names:
            entry = self._files.get(name)
            if entry is not None and entry.get("command") != self.command:
                continue  # another command's file, refused or kept by prepare
            digest = _sha256(self.path / name)
            if digest is None:
                self._files.pop(name, None)
                self._remove_empty_parents(self.path / name)
            else:
                self._files[name] = {"command": self.command, "sha256": digest}

    def _save(self) -> None:
        data: dict[str, Any] = {"format": _FORMAT, "files": dict(sorted(self._files.items()))}
        holding = self._holder
        if holding is not None:
            data["holder"] = {
                "command": holding.command,
                "pid": holding.pid,
                "since": holding.since,
            }
        write_text_atomic(self.path / MANIFEST, json.dumps(data, indent=1) + "\n")


def _already(folder: OutputFolder, previous: list[str]) -> str:
    shown = ", ".join(previous[:3]) + (
        f" and {len(previous) - 3} more" if len(previous) > 3 else ""
    )
    return (
        f"{folder.path}: already holds the files of terrain-odom {folder.command} ({shown}); "
        "choose another --out, or --overwrite to replace them"
    )


@contextlib.contextmanager
def writing(path: str | Path, command: str) -> Iterator[OutputFolder]:
    """Create and lock the folder ``path`` for ``command``; record its files on leaving.

    A command that writes nothing (refused) leaves the folder as it was: a
    folder it created is removed again if still empty.

    Raises
    ------
    FolderInUseError
        Another command (of this or another process) holds the folder.
    InputFileError, OutputFileError
        As :func:`create_folder`.
    """
    created = not os.path.lexists(path)
    folder = create_folder(path)
    fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            held = _holder_of(_read_manifest(folder))
            raise FolderInUseError(
                f"{folder}: in use by {held.describe()}; wait for it to finish, or choose "
                "another --out"
            ) from None
        except OSError as exc:  # no locks on this file system: say so, never guess
            if exc.errno not in (errno.ENOLCK, errno.EOPNOTSUPP, errno.EINVAL):
                raise
            raise OutputFileError(exc.errno, "cannot lock the folder", str(folder)) from None
        manifest = _read_manifest(folder)
        original = _read_bytes(folder / MANIFEST)
        opened = OutputFolder(folder, command, dict(manifest.get("files", {})))
        since = datetime.datetime.now().isoformat(sep=" ", timespec="seconds")
        opened._holder = Holder(command, os.getpid(), since)
        try:
            opened._save()
        except OutputFileError as exc:  # the folder cannot be written: name it, not the manifest
            raise OutputFileError(exc.errno, exc.strerror, str(folder)) from None
        try:
            yield opened
        finally:
            opened._holder = None
            with contextlib.suppress(OSError):  # a full disk: the error at hand says more
                if opened._claimed:
                    opened.record()
                    opened._save()
                else:  # refused, or only checked: the folder as it was
                    _restore(folder / MANIFEST, original)
                    if created:
                        folder.rmdir()  # made for this command: gone again (if still empty)
    finally:
        os.close(fd)  # releases the lock


@contextlib.contextmanager
def replacing(
    path: str | Path,
    command: str,
    names: Iterable[str],
    *,
    overwrite: bool = True,
    all_previous: bool = True,
) -> Iterator[Path]:
    """Lock the folder ``path`` while ``command`` writes ``names`` into it (:func:`writing`).

    Its previous files (all, or only those among ``names``:
    ``all_previous``) are removed first if ``overwrite`` (refused
    otherwise); a file among ``names`` it did not write is refused
    (:meth:`OutputFolder.prepare`).
    """
    with writing(path, command) as folder:
        folder.prepare(names, overwrite=overwrite, all_previous=all_previous)
        yield folder.path


def writing_if(
    path: str | Path | None, command: str
) -> contextlib.AbstractContextManager[OutputFolder | None]:
    """:func:`writing` the folder ``path`` for ``command``, or nothing (None) if ``path`` is None."""
    return contextlib.nullcontext() if path is None else writing(path, command)
