"""Frames decode straight to RGB: the pixels of OpenCV's BGR decoding, channels reversed."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from terrain_odom.io.images import decode_image_rgb

RNG = np.random.default_rng(4)
COLOUR = RNG.integers(0, 256, (37, 53, 3), dtype=np.uint8)


@pytest.mark.parametrize(
    ("extension", "image", "params"),
    [
        (".jpg", COLOUR, [cv2.IMWRITE_JPEG_QUALITY, 95]),
        (".jpg", COLOUR[..., 0], []),  # grey JPEG: replicated
        (".png", COLOUR, []),
        (".png", np.dstack([COLOUR, COLOUR[..., :1]]), []),  # alpha: dropped
        (".png", (COLOUR[..., 0].astype(np.uint16) * 257 + 3), []),  # 16-bit grey: scaled
    ],
)
def test_decoded_rgb_is_the_bgr_decoding_reversed(extension, image, params):
    ok, encoded = cv2.imencode(extension, image, params)
    assert ok
    bgr = cv2.imdecode(encoded, cv2.IMREAD_COLOR)
    rgb = decode_image_rgb(encoded.tobytes())
    assert rgb is not None and rgb.dtype == np.uint8 and rgb.shape == bgr.shape
    np.testing.assert_array_equal(rgb, bgr[..., ::-1])
    assert decode_image_rgb(b"not an image") is None
    assert decode_image_rgb(b"") is None
