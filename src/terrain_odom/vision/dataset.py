"""Labelled image sets and parallel feature extraction.

A labelled image set (:class:`LabelledImages`, listed from a folder with one
sub-folder per terrain class by :func:`terrain_odom.io.images.scan_image_folder`)
names its images; the extraction decodes each through the ``read`` function
it is given (e.g. :func:`terrain_odom.io.images.read_image_rgb`), so this
module itself reads no file. Images may differ in size, and so in their
number of tiles: their features are flat, one row per tile, with the index
of each row's image (:class:`LabelledFeatures`).
"""

from __future__ import annotations

import contextlib
import os
import time
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TypeAlias

import cv2
import numpy as np
from joblib import Parallel, delayed
from numpy.typing import NDArray
from tqdm import tqdm

from terrain_odom.config.classifier import ClassifierConfig
from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.vision.features import image_features

__all__ = [
    "ImageReader",
    "LabelledImages",
    "SkippedImage",
    "LabelledFeatures",
    "extract_features",
    "extract_feature_sets",
]

ImageReader: TypeAlias = Callable[[Path], NDArray[np.uint8] | None]
"""Decodes one image file to RGB uint8 (H, W, 3), or returns ``None`` if it cannot.

Given to the extraction by the caller; a module-level function, so that it
reaches worker processes.
"""


@dataclass(frozen=True)
class LabelledImages:
    """The images of a labelled folder.

    Attributes
    ----------
    root : Path
        The folder.
    classes : tuple of str
        Class names (sub-folder names), sorted.
    paths : tuple of Path
        Image files, sorted by class then path.
    labels : tuple of str
        Class of each image.
    """

    root: Path
    classes: tuple[str, ...]
    paths: tuple[Path, ...]
    labels: tuple[str, ...]

    def counts(self) -> dict[str, int]:
        """Return the number of images of each class, in class order."""
        counter = Counter(self.labels)
        return {name: counter[name] for name in self.classes}


@dataclass(frozen=True)
class SkippedImage:
    """An image left out of a data set, and why."""

    path: Path
    reason: str


@dataclass(frozen=True)
class LabelledFeatures:
    """Features of the readable images of a labelled folder for one configuration.

    Attributes
    ----------
    config : ClassifierConfig
        Configuration the features were computed with.
    features : ndarray of float64, shape (n_tiles, n_features)
        :func:`~terrain_odom.vision.features.image_features` of every
        image, concatenated in image order (an image's tiles are adjacent).
    region : ndarray of intp, shape (n_tiles,)
        Image of each row of ``features`` (index into ``labels`` and ``paths``).
    labels : ndarray of str, shape (n_images,)
    paths : tuple of Path
        The images, in the order of ``labels``.
    seconds : ndarray of float64, shape (n_images,)
        Feature-extraction time of each image, s (decoding excluded; measured
        in the worker process, so it includes contention from the others).
    classes : tuple of str
    skipped : tuple of SkippedImage
        Images that could not be read or used.
    """

    config: ClassifierConfig
    features: NDArray[np.float64]
    region: NDArray[np.intp]
    labels: NDArray[np.str_]
    paths: tuple[Path, ...]
    seconds: NDArray[np.float64]
    classes: tuple[str, ...]
    skipped: tuple[SkippedImage, ...]

    def counts(self) -> dict[str, int]:
        """Return the number of used images of each class, in class order."""
        counter = Counter(self.labels.tolist())
        return {name: counter[name] for name in self.classes}

    def select(self, images: Sequence[int] | NDArray[np.integer]) -> LabelledFeatures:
        """Return the data of some images, all their tiles, in the given order.

        Parameters
        ----------
        images : sequence of int
            Distinct image indices (into ``labels``).

        Returns
        -------
        LabelledFeatures
            Image ``images[j]`` becomes image ``j``: its rows of ``features``
            (in their order) have ``region == j``. ``skipped`` is unchanged.
        """
        images = np.asarray(images, dtype=np.intp)
        renumber = np.full(self.labels.size, -1, dtype=np.intp)
        renumber[images] = np.arange(images.size)
        if np.count_nonzero(renumber >= 0) != images.size:
            raise ValueError("select: image indices must be distinct")
        new_region = renumber[self.region]
        rows = np.flatnonzero(new_region >= 0)
        rows = rows[np.argsort(new_region[rows], kind="stable")]
        return replace(
            self,
            features=self.features[rows],
            region=new_region[rows],
            labels=self.labels[images],
            paths=tuple(self.paths[i] for i in images),
            seconds=self.seconds[images],
        )


def _extract_one(
    path: Path, configs: Sequence[ClassifierConfig], read: ImageReader
) -> tuple[list[NDArray], list[float]] | str:
    """Features and extraction time (s) of one image per configuration, or why it failed."""
    image = read(path)
    if image is None:
        return "cannot be read as an image"
    features, seconds = [], []
    for config in configs:
        start = time.perf_counter()
        features.append(image_features(image, config))
        seconds.append(time.perf_counter() - start)
    return features, seconds


def _extract_in_worker(
    path: Path, configs: Sequence[ClassifierConfig], read: ImageReader
) -> tuple[list[NDArray], list[float]] | str:
    """:func:`_extract_one` in a worker process: OpenCV single-threaded (one worker per core)."""
    cv2.setNumThreads(1)
    return _extract_one(path, configs, read)


@contextlib.contextmanager
def _opencv_threads(threads: int) -> Iterator[None]:
    """Run the block with OpenCV's thread pool set to ``threads``; restore it after."""
    previous = cv2.getNumThreads()
    cv2.setNumThreads(threads)
    try:
        yield
    finally:
        cv2.setNumThreads(previous)


def _default_jobs() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def extract_feature_sets(
    images: LabelledImages,
    configs: Sequence[ClassifierConfig],
    *,
    read: ImageReader,
    jobs: int | None = None,
    progress: bool | None = None,
) -> list[LabelledFeatures]:
    """Compute the features of every image for several configurations.

    Each image is decoded once; configurations with the same feature settings
    (:meth:`ClassifierConfig.feature_key`) share one computation.

    Parameters
    ----------
    images : LabelledImages
    configs : sequence of ClassifierConfig
    read : ImageReader
        Decodes an image file (e.g. :func:`terrain_odom.io.images.read_image_rgb`);
        an image it returns ``None`` for is skipped.
    jobs : int, optional
        Worker processes (default: the usable cores); 1 runs in this process.
    progress : bool, optional
        Show a progress bar (default: only on a terminal).

    Returns
    -------
    list of LabelledFeatures
        One per configuration, with the same images and skipped images.

    Raises
    ------
    ConfigError
        ``jobs < 1``.
    InputFileError
        Fewer than 2 classes, or a class without any usable image, remain.
    """
    jobs = _default_jobs() if jobs is None else jobs
    if jobs < 1:
        raise ConfigError(f"jobs: must be a whole number >= 1, got {jobs!r}")
    keys = [tuple(config.feature_key().items()) for config in configs]
    unique_keys = list(dict.fromkeys(keys))
    unique = [configs[keys.index(key)] for key in unique_keys]
    results = _run_all(images.paths, unique, read, jobs, progress)
    return _collect(images, configs, [unique_keys.index(key) for key in keys], results)


def _run_all(
    paths: Sequence[Path],
    configs: list[ClassifierConfig],
    read: ImageReader,
    jobs: int,
    progress: bool | None,
) -> list[tuple[list[NDArray], list[float]] | str]:
    """:func:`_extract_one` over all images, in order, in ``jobs`` processes."""
    disable = None if progress is None else not progress
    with (
        tqdm(total=len(paths), desc="features", unit="image", disable=disable) as bar,
        _opencv_threads(1),  # as in every worker: one image per core, no thread contention
    ):
        if jobs == 1:
            tasks = (_extract_one(path, configs, read) for path in paths)
        else:  # loky workers do not re-run the caller's __main__ (unlike spawn)
            parallel = Parallel(n_jobs=jobs, return_as="generator", batch_size="auto")
            # absolute: a reused worker keeps the working directory it started in
            tasks = parallel(
                delayed(_extract_in_worker)(Path(path).absolute(), configs, read) for path in paths
            )
        results = []
        for result in tasks:
            results.append(result)
            bar.update()
    return results


def _collect(
    images: LabelledImages,
    configs: Sequence[ClassifierConfig],
    slots: list[int],
    results: list[tuple[list[NDArray], list[float]] | str],
) -> list[LabelledFeatures]:
    """Assemble per-image results into one :class:`LabelledFeatures` per configuration.

    ``slots[i]`` is the index, in each image's result lists, of ``configs[i]``.
    """
    skipped = tuple(
        SkippedImage(path, result)
        for path, result in zip(images.paths, results, strict=True)
        if isinstance(result, str)
    )
    good = [i for i, result in enumerate(results) if not isinstance(result, str)]
    labels = np.array([images.labels[i] for i in good], dtype=str)
    used = Counter(labels.tolist())
    empty = [name for name in images.classes if not used[name]]
    if empty:
        raise InputFileError(f"{images.root}: no readable image in class(es) {empty}")
    out = []
    for config, slot in zip(configs, slots, strict=True):
        per_image = [results[i][0][slot] for i in good]
        tile_counts = [len(rows) for rows in per_image]
        out.append(
            LabelledFeatures(
                config=config,
                features=np.concatenate(per_image),
                region=np.repeat(np.arange(len(per_image)), tile_counts),
                labels=labels,
                paths=tuple(images.paths[i] for i in good),
                seconds=np.array([results[i][1][slot] for i in good]),
                classes=images.classes,
                skipped=skipped,
            )
        )
    return out


def extract_features(
    images: LabelledImages,
    config: ClassifierConfig,
    *,
    read: ImageReader,
    jobs: int | None = None,
    progress: bool | None = None,
) -> LabelledFeatures:
    """Compute the features of every image for one configuration.

    See :func:`extract_feature_sets` for the parameters and errors.
    """
    return extract_feature_sets(images, [config], read=read, jobs=jobs, progress=progress)[0]
