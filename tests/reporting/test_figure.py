"""The Agg figure and its PNG: ``save_png`` writes ``savefig``'s bytes in one draw."""

from __future__ import annotations

import io
import struct
from typing import Any

import pytest

from terrain_odom.reporting.figure import DPI, new_figure, save_png


def _figure() -> Any:
    """Return a small figure whose layout matters: a legend outside the axes, title, labels."""
    fig = new_figure(5.0, 3.0)
    ax = fig.subplots()
    ax.plot([0.0, 1.0, 2.0], [0.0, -1234.5, 0.5], label="a legend label")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    ax.set_title("title")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    return fig


def _png_size(data: bytes) -> tuple[int, int]:
    """Width and height, pixels, from a PNG's IHDR chunk."""
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


@pytest.mark.parametrize("dpi", [DPI, 72])
def test_save_png_writes_the_bytes_savefig_writes(dpi: int) -> None:
    """Laid out (constrained) and drawn as ``savefig`` does: the same PNG, at ``dpi``."""
    ours, reference = io.BytesIO(), io.BytesIO()
    save_png(_figure(), ours, dpi=dpi)
    _figure().savefig(reference, format="png", dpi=dpi)
    assert ours.getvalue() == reference.getvalue()
    assert _png_size(ours.getvalue()) == (5 * dpi, 3 * dpi)


def test_save_png_draws_the_figure_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """One draw (the layout in it), where ``savefig`` draws twice; the layout was applied."""
    fig = _figure()
    ax = fig.axes[0]
    draws = []
    draw = fig.draw
    monkeypatch.setattr(fig, "draw", lambda renderer: draws.append(1) or draw(renderer))
    save_png(fig, io.BytesIO())
    assert len(draws) == 1
    assert ax.get_position().x1 < 0.7  # the constrained layout made room for the legend
    fig.savefig(io.BytesIO(), format="png", dpi=DPI)
    assert len(draws) == 3  # savefig: a draw to lay out, then the draw
