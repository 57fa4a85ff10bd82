"""Fixtures of the plot tests: a figure's PNG decoded, not blank; text that must not overlap."""

from __future__ import annotations

import io
from typing import Any

import cv2
import numpy as np
import pytest

from terrain_odom.reporting.figure import save_png


def _png_of(fig: Any) -> np.ndarray:
    """Return ``fig`` written by ``save_png`` and decoded (BGR), checking it is a PNG."""
    handle = io.BytesIO()
    save_png(fig, handle)
    data = handle.getvalue()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    assert image is not None
    return image


def _assert_not_blank(image: np.ndarray) -> None:
    """Assert that an image shows a drawing: many pixels not white, several grey levels."""
    grey = image.mean(axis=2)
    assert (grey < 250).mean() > 0.02
    assert grey.std() > 10


def _assert_apart(fig: Any, texts: list[Any]) -> None:
    """No two of the (visible, non-empty) ``texts`` overlap once ``fig`` is drawn."""
    renderer = fig.canvas.get_renderer()
    fig.draw_without_rendering()
    boxes = [t.get_window_extent(renderer) for t in texts if t.get_visible() and t.get_text()]
    for i, a in enumerate(boxes):
        for b in boxes[i + 1 :]:
            assert not a.overlaps(b), (a, b)


@pytest.fixture(scope="session")
def png_of() -> Any:
    """Return a function: a figure to its decoded PNG (BGR)."""
    return _png_of


@pytest.fixture(scope="session")
def not_blank() -> Any:
    """Return a function asserting that a decoded PNG shows a drawing."""
    return _assert_not_blank


@pytest.fixture(scope="session")
def apart() -> Any:
    """Return a function asserting that texts of a figure do not overlap."""
    return _assert_apart
