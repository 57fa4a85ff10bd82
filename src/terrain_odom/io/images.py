"""Image files: labelled image folders and decoding to RGB.

A labelled image folder has one sub-folder per terrain class, named after the
class, holding its images (at any depth; png, jpg, jpeg, bmp, tif, tiff in
any letter case; hidden files and folders are ignored)::

    images/
      carpet/  0001.jpg  0002.jpg ...
      wood/    a.png ...

Images are decoded with OpenCV (BGR) and converted to RGB here, at the edge;
everything after works on RGB.
"""

from __future__ import annotations

import os
import stat
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, BinaryIO

import numpy as np
from numpy.typing import NDArray

from terrain_odom.errors import InputFileError

if TYPE_CHECKING:  # the feature code (scikit-image, joblib) loads when a folder is scanned
    from terrain_odom.vision.dataset import LabelledImages

__all__ = [
    "IMAGE_SUFFIXES",
    "MAX_IMAGE_BYTES",
    "scan_image_folder",
    "read_image_bytes",
    "open_image_file",
    "decode_image_rgb",
    "read_image_rgb",
]

IMAGE_SUFFIXES = frozenset({".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff"})
"""Image file suffixes recognised in folders (compared in lower case)."""


def _check_class_folders(root: Path, class_dirs: list[Path]) -> None:
    """Refuse class folders that share images: one inside another, or holding the root.

    A symbolic link to the images folder itself (or to another class) would
    train the same images under two labels.

    Raises
    ------
    InputFileError
        Naming the two folders.
    """
    real = root.resolve()
    resolved = [(d, d.resolve()) for d in class_dirs]
    for class_dir, target in resolved:
        if real.is_relative_to(target):
            raise InputFileError(
                f"{class_dir}: class folder is (a link to) {target}, which holds the images "
                "folder itself: its images would be trained under two labels"
            )
        for other, other_target in resolved:
            if other != class_dir and other_target.is_relative_to(target):
                raise InputFileError(
                    f"{other}: class folder lies within the class folder {class_dir} "
                    f"({other_target}): its images would be trained under two labels"
                )


def _is_hidden(path: Path, root: Path) -> bool:
    return any(part.startswith(".") for part in path.relative_to(root).parts)


def scan_image_folder(root: str | Path) -> LabelledImages:
    """List the images of a labelled folder (one sub-folder per class).

    Raises
    ------
    InputFileError
        The folder does not exist, has fewer than 2 class sub-folders, or a
        class sub-folder has no image.
    """
    root = Path(root)
    if not root.is_dir():
        raise InputFileError(f"{root}: image folder not found")
    class_dirs = sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith("."))
    if len(class_dirs) < 2:
        raise InputFileError(
            f"{root}: needs one sub-folder per terrain class and at least 2 classes, "
            f"found {[p.name for p in class_dirs]}"
        )
    _check_class_folders(root, class_dirs)
    paths: list[Path] = []
    labels: list[str] = []
    for class_dir in class_dirs:
        images = sorted(
            p
            for p in class_dir.rglob("*")
            if p.suffix.lower() in IMAGE_SUFFIXES and p.is_file() and not _is_hidden(p, root)
        )
        if not images:
            raise InputFileError(
                f"{class_dir}: class '{class_dir.name}' has no images "
                f"({', '.join(sorted(s[1:] for s in IMAGE_SUFFIXES))})"
            )
        paths += images
        labels += [class_dir.name] * len(images)
    from terrain_odom.vision.dataset import LabelledImages

    return LabelledImages(root, tuple(p.name for p in class_dirs), tuple(paths), tuple(labels))


MAX_IMAGE_BYTES = 256 * 2**20
"""Largest image file read, bytes (a camera frame is a few MB at most)."""


def read_image_bytes(path: str | Path) -> tuple[bytes | None, str]:
    """Return an image file's bytes, or ``(None, problem)``; never blocks.

    Only a regular file is read (a FIFO, a device or a folder named like an
    image is a problem, not a wait), and at most :data:`MAX_IMAGE_BYTES`.

    Examples
    --------
    >>> import os, tempfile
    >>> fifo = os.path.join(tempfile.mkdtemp(), "0.5.png")
    >>> os.mkfifo(fifo)
    >>> read_image_bytes(fifo)
    (None, 'not a regular file (a FIFO)')
    """
    handle, problem = open_image_file(path)
    if handle is None:
        return None, problem
    with handle:
        try:
            data = handle.read(MAX_IMAGE_BYTES + 1)
        except OSError as exc:
            return None, f"unreadable ({exc.strerror})"
    if len(data) > MAX_IMAGE_BYTES:
        return None, f"larger than {MAX_IMAGE_BYTES >> 20} MiB"
    return data, ""


def open_image_file(path: str | Path) -> tuple[BinaryIO | None, str]:
    """Open an image file for reading, or return ``(None, problem)``; never blocks.

    Only a regular file of at most :data:`MAX_IMAGE_BYTES` is opened (a
    FIFO, a device or a folder named like an image is a problem, not a wait).
    """
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except FileNotFoundError:
        return None, "missing"
    except OSError as exc:
        return None, f"unreadable ({exc.strerror})"
    info = os.fstat(fd)
    if not stat.S_ISREG(info.st_mode):
        os.close(fd)
        return None, f"not a regular file ({_kind(info.st_mode)})"
    if info.st_size > MAX_IMAGE_BYTES:
        os.close(fd)
        return None, f"larger than {MAX_IMAGE_BYTES >> 20} MiB"
    return os.fdopen(fd, "rb"), ""


def _kind(mode: int) -> str:
    kinds = (
        (stat.S_ISFIFO, "a FIFO"),
        (stat.S_ISDIR, "a folder"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    )
    return next((name for test, name in kinds if test(mode)), "not a file")


def decode_image_rgb(data: bytes) -> NDArray[np.uint8] | None:
    """Decode an image file's bytes to RGB uint8 (H, W, 3); ``None`` if they are no image.

    Grey images are replicated to 3 channels, an alpha channel is dropped,
    16-bit images are scaled to 8 bits (OpenCV's ``IMREAD_COLOR``).
    """
    import cv2  # ~0.1 s: loaded when an image is read, not by a wheel-only run

    buffer = np.frombuffer(data, dtype=np.uint8)
    bgr = cv2.imdecode(buffer, cv2.IMREAD_COLOR) if buffer.size else None
    if bgr is None:
        return None
    return np.asarray(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB), dtype=np.uint8)


def read_image_rgb(path: str | Path) -> NDArray[np.uint8] | None:
    """Decode an image file to RGB uint8 (H, W, 3); ``None`` if it cannot be read or decoded.

    See :func:`read_image_bytes` (regular files only, size-bounded) and
    :func:`decode_image_rgb`.
    """
    data, _ = read_image_bytes(path)
    return None if data is None else decode_image_rgb(data)


def median_short_side(paths: Sequence[str | Path]) -> float | None:
    """Median shorter side of the images, px, from their headers (no decoding); ``None`` if none is readable.

    What ``min_tile_size: auto`` and the default ``--tune`` grid are scaled to
    (:func:`terrain_odom.vision.features.resolve_scale`). Unreadable images
    (and files no image is read from: :func:`open_image_file`) are left out
    here; the feature extraction reports them.
    """
    from PIL import Image, UnidentifiedImageError

    sides = []
    for path in paths:
        handle, _ = open_image_file(path)
        if handle is None:
            continue
        try:
            with handle, warnings.catch_warnings():
                warnings.simplefilter("ignore", Image.DecompressionBombWarning)  # a size only
                with Image.open(handle) as image:
                    sides.append(min(image.size))
        except (OSError, UnidentifiedImageError, ValueError, Image.DecompressionBombError):
            continue
    return float(np.median(sides)) if sides else None
