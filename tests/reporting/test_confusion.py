"""reporting.confusion: confusion matrices that stay legible from 2 to 12 classes."""

from __future__ import annotations

import numpy as np
import pytest

from terrain_odom.reporting.confusion import confusion_figure, confusion_layout


def _matrix(n: int) -> np.ndarray:
    counts = np.ones((n, n)) + np.eye(n) * 3 * n
    return 100.0 * counts / counts.sum(axis=1, keepdims=True)


def test_cells_and_numbers_shrink_with_the_class_count():
    layouts = [confusion_layout(n) for n in (2, 7, 12, 30)]
    cells = [cell for cell, _, _ in layouts]
    sizes = [size for _, size, _ in layouts]
    assert cells == sorted(cells, reverse=True) and cells[-1] == 0.32
    assert sizes == sorted(sizes, reverse=True) and sizes[-1] >= 5
    assert [fmt.format(100.0) for _, _, fmt in layouts] == ["100.0", "100.0", "100", "100"]


@pytest.mark.parametrize("n", [2, 7, 12])
def test_numbers_titles_and_labels_do_not_overlap(n, png_of, not_blank, apart):
    classes = [f"long_terrain_name_{i}_wet" if i % 3 == 0 else f"class_{i}" for i in range(n)]
    panels = [("chosen: mean 91.3 %", _matrix(n)), ("paper (Chen et al.): mean 85.0 %", _matrix(n))]
    fig = confusion_figure(classes, panels)
    matrices = [ax for ax in fig.axes if ax.images]
    assert len(matrices) == 2
    for ax, (title, percent) in zip(matrices, panels, strict=True):
        assert ax.get_title().replace("\n", " ") == title
        assert (ax.get_xlabel(), ax.get_ylabel()) == ("predicted", "true")
        numbers = ax.texts
        assert len(numbers) == n * n
        assert float(numbers[0].get_text()) == pytest.approx(percent[0, 0], abs=0.5)
        apart(fig, numbers)
        apart(fig, ax.get_xticklabels())
        apart(fig, ax.get_yticklabels())
    apart(fig, [ax.title for ax in matrices])
    not_blank(png_of(fig))
