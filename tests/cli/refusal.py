"""What a refused command must leave: exit 2, one stderr line, its inputs byte-identical."""

from __future__ import annotations

from pathlib import Path

import pytest

from terrain_odom.cli.main import main
from terrain_odom.io.folder import MANIFEST


def snapshot(folder: Path) -> dict[str, bytes]:
    """Return every file under ``folder`` (but FIFOs and the manifest) by relative path."""
    return {
        str(p.relative_to(folder)): p.read_bytes()
        for p in sorted(folder.rglob("*"))
        if p.is_file() and p.name != MANIFEST
    }


def refused(argv: list[str], capsys: pytest.CaptureFixture[str], *folders: Path) -> str:
    """Run ``argv``: exit 2, one stderr line, every file of ``folders`` byte-identical; the line."""
    before = [snapshot(f) for f in folders]
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("terrain-odom: error: "), err
    assert [snapshot(f) for f in folders] == before
    return err
