"""reporting.plots: PNGs of the size asked for, drawn without a display."""

from __future__ import annotations

import io

import cv2
import numpy as np

from terrain_odom.reporting.plots import plot_frames


def _decode(data: bytes) -> np.ndarray:
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    assert image is not None, "not a readable PNG"
    return image


def test_frame_plot_is_a_png_of_the_figure_size_with_wrong_labels_in_red():
    t = np.arange(6.0)
    truth = ["grass"] * 3 + ["gravel"] * 3
    labels = ["grass", "grass", "gravel", "gravel", "gravel", "gravel"]  # one wrong
    handle = io.BytesIO()
    plot_frames(handle, t, labels, truth)
    data = handle.getvalue()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    image = _decode(data)
    assert image.shape[1] == 8.0 * 110  # 8 in at 110 dpi
    assert image.shape[0] == round((2.2 + 0.3 * 2) * 110)
    b, g, r = (image[..., i].astype(int) for i in range(3))
    assert ((r > 200) & (g < 80) & (b < 80)).any()  # the red cross of the wrong label
