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

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from terrain_odom.errors import InputFileError

if TYPE_CHECKING:  # the feature code (scikit-image, joblib) loads when a folder is scanned
    from terrain_odom.vision.dataset import LabelledImages

__all__ = ["IMAGE_SUFFIXES", "decode_image_rgb", "scan_image_folder", "read_image_rgb"]

IMAGE_SUFFIXES = frozenset({".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff"})
"""Image file suffixes recognised in folders (compared in lower case)."""


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


def read_image_rgb(path: str | Path) -> NDArray[np.uint8] | None:
    """Decode an image file to RGB uint8 (H, W, 3); ``None`` if it cannot be decoded.

    Grey images are replicated to 3 channels, an alpha channel is dropped,
    16-bit images are scaled to 8 bits (OpenCV's ``IMREAD_COLOR``).
    """
    try:
        data = np.fromfile(path, dtype=np.uint8)
    except OSError:
        return None
    return decode_image_rgb(data)


def decode_image_rgb(data: NDArray[np.uint8]) -> NDArray[np.uint8] | None:
    """Decode the bytes of an image file (JPEG, PNG, ...) as :func:`read_image_rgb` does."""
    import cv2  # ~0.1 s: loaded when an image is read, not by a wheel-only run

    bgr = cv2.imdecode(data, cv2.IMREAD_COLOR) if data.size else None
    if bgr is None:
        return None
    return np.asarray(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB), dtype=np.uint8)
