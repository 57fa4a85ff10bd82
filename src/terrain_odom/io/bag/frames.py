"""Camera frames from ``sensor_msgs/Image`` and ``CompressedImage`` messages, written one by one.

:func:`write_frame` writes one message as an image file (atomically); a
``CompressedImage`` already in JPEG is copied byte for byte when JPEG is
asked, anything else is decoded with ``rosbags-image`` and encoded with
OpenCV. :func:`write_frames_csv` writes the ``frames.csv`` index that
``run --images`` reads (``t,file``).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from rosbags.image import ImageConversionError, ImageFormatError, message_to_cvimage

from terrain_odom.errors import InputFileError
from terrain_odom.io.atomic import write_atomic, write_text_atomic
from terrain_odom.io.bag.messages import COMPRESSED_IMAGE
from terrain_odom.io.images import decode_image_rgb

__all__ = ["FRAME_FORMATS", "frame_rgb", "write_frame", "write_frames_csv"]

#: Image formats of the frames written, by file suffix.
FRAME_FORMATS = ("jpg", "png")


def _is_jpeg(msg: Any, msgtype: str) -> bool:
    """Whether a message is a ``CompressedImage`` holding a JPEG (its magic bytes)."""
    return msgtype == COMPRESSED_IMAGE and bytes(msg.data[:3]) == b"\xff\xd8\xff"


def _decode(msg: Any, msgtype: str, where: str) -> np.ndarray:
    """Decode an image message to an OpenCV image (BGR, or single channel)."""
    if msgtype != COMPRESSED_IMAGE:
        _check_raw_size(msg, where)
    try:
        if msgtype == COMPRESSED_IMAGE:
            image = cv2.imdecode(np.frombuffer(bytes(msg.data), np.uint8), cv2.IMREAD_ANYCOLOR)
        else:
            image = message_to_cvimage(msg, _color_space(msg))
    except (ImageConversionError, ImageFormatError, ValueError, TypeError, cv2.error) as exc:
        raise InputFileError(f"{where}: cannot decode the image ({exc})") from None
    if image is None or not np.asarray(image).size:
        kind = getattr(msg, "format", None) or getattr(msg, "encoding", "")
        raise InputFileError(f"{where}: cannot decode the image (not a {kind} image)")
    return np.asarray(image)


def _check_raw_size(msg: Any, where: str) -> None:
    """Refuse a raw ``Image`` whose data disagree with its height, width and row step."""
    height, width, step = int(msg.height), int(msg.width), int(msg.step)
    size = len(msg.data)
    if height <= 0 or width <= 0 or step < width or size < height * step:
        raise InputFileError(
            f"{where}: an Image of {width}x{height} px with rows of {step} bytes needs "
            f"{height * step} bytes of data, it holds {size}"
        )


def _decode_8bit(msg: Any, msgtype: str, where: str) -> np.ndarray:
    """Decode an image message to 8-bit BGR (or mono)."""
    image = _decode(msg, msgtype, where)
    if image.dtype != np.uint8:  # 16-bit or float images: scale to 8 bit for the classifier
        low, high = float(image.min()), float(image.max())
        image = ((image - low) * (255.0 / max(high - low, 1e-12))).astype(np.uint8)
    return image


def frame_rgb(msg: Any, msgtype: str, where: str) -> np.ndarray:
    """Decode an image message to the RGB uint8 frame (H, W, 3) the classifier takes.

    A compressed image decodes as its file would (:func:`~terrain_odom.io.images.decode_image_rgb`,
    as ``run`` reads an imported frame); a raw image as :func:`write_frame`
    writes it, in RGB. ``msg.data`` may be ``bytes`` (``rospy``) or an array (``rosbags``).

    Raises
    ------
    InputFileError
        If the message cannot be decoded.
    """
    if msgtype == COMPRESSED_IMAGE:
        rgb = decode_image_rgb(bytes(msg.data))
        if rgb is None:
            raise InputFileError(f"{where}: cannot decode the image (not a {msg.format} image)")
        return rgb
    image = _decode_8bit(msg, msgtype, where)
    code = cv2.COLOR_GRAY2RGB if image.ndim == 2 else cv2.COLOR_BGR2RGB
    return np.asarray(cv2.cvtColor(image, code), dtype=np.uint8)


def _encode(msg: Any, msgtype: str, fmt: str, where: str) -> bytes:
    """Decode an image message to 8-bit BGR (or mono) and encode it as ``fmt``."""
    image = _decode_8bit(msg, msgtype, where)
    ok, data = cv2.imencode(f".{fmt}", image)
    if not ok:
        raise InputFileError(f"{where}: cannot encode the image as {fmt}")
    return bytes(data.tobytes())


def _color_space(msg: Any) -> str | None:
    """``bgr8`` (what OpenCV writes) for a raw colour ``Image``; None keeps the image as it is.

    Compressed images decode to BGR already; single-channel images stay so.
    """
    encoding = str(getattr(msg, "encoding", "")).lower()
    single = encoding.startswith("mono") or encoding.endswith("c1")
    return None if not encoding or single else "bgr8"


def write_frame(msg: Any, msgtype: str, path: str | os.PathLike[str], fmt: str, where: str) -> None:
    """Write one image message to ``path`` in ``fmt`` (``jpg`` or ``png``), atomically.

    Parameters
    ----------
    where : str
        The bag and topic, for the one-line error on an undecodable image.

    Raises
    ------
    InputFileError
        If the message cannot be decoded.
    """
    jpeg = fmt == "jpg" and _is_jpeg(msg, msgtype)
    data = bytes(msg.data) if jpeg else _encode(msg, msgtype, fmt, where)
    write_atomic(path, lambda handle: handle.write(data))


def write_frames_csv(
    path: str | os.PathLike[str], t: Sequence[float], files: Sequence[str]
) -> None:
    """Write ``frames.csv`` (``t,file``; t to 1 microsecond) sorted by time, atomically."""
    order = np.argsort(np.asarray(t, dtype=float), kind="stable")
    lines = ["t,file", *(f"{t[i]:.6f},{Path(files[i]).as_posix()}" for i in order)]
    write_text_atomic(path, "\n".join(lines) + "\n")
