"""Tuning the classifier on small patches: untuned defaults against ``--tune`` (nested CV).

Builds, outside the repository, a labelled folder of square patches (64x64 px
by default) cut at seeded random places from real images, then runs
``report accuracy`` on it untuned and with ``--tune`` (nested cross-validation,
the default grid or ``--grid``) through the app API, and prints the
per-class and mean accuracies, each outer fold's choice and the run time.

Sources (``--source``):

* ``skimage``: scikit-image's ground photos ``grass()``, ``gravel()`` and
  ``brick()`` (512x512 grey), ``--crops`` patches of each (one class each);
* ``indoor``: the floor photos of ``../shared/data/indoor_surface`` (carpet,
  tiles, wood; short side 320 px): a seeded subset of ``--photos`` photos
  per class, ``--crops`` patches of each photo.

The shared photos are only read; the patches go to ``--out`` (default: a
temporary folder, deleted at the end), which must lie outside the repository.
The defaults (``indoor``: 240 photos per class, a seeded subset of the
1,774, one patch each) keep every patch from a different photo, so that
cross-validation folds never share a photo. A run takes 13 s with the
default grid and 21 s with ``config/grid_small_patches.yaml`` on the shared
2-core machine (load average about 3); up to a minute when it is busier.

Usage::

    python bench/small_patches.py [--source indoor|skimage] [--photos 240] [--crops 1]
        [--size 64] [--grid config/grid_small_patches.yaml] [--out DIR] [--jobs 1]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np
from skimage import data

from terrain_odom.app.train import AccuracyReport, report_accuracy
from terrain_odom.io.images import read_image_rgb, scan_image_folder

REPO = Path(__file__).resolve().parents[1]
INDOOR = REPO.parent / "shared" / "data" / "indoor_surface"
SKIMAGE_CLASSES = ("grass", "gravel", "brick")
SEED = 0


def random_crops(image: np.ndarray, count: int, size: int, rng: np.random.Generator) -> list:
    """Return ``count`` ``size`` x ``size`` crops of ``image`` at uniform random corners."""
    rows, cols = image.shape[:2]
    if rows < size or cols < size:
        raise ValueError(f"image of {cols}x{rows} px is smaller than a {size} px patch")
    corners = zip(
        rng.integers(0, rows - size + 1, count),
        rng.integers(0, cols - size + 1, count),
        strict=True,
    )
    return [image[r : r + size, c : c + size] for r, c in corners]


def skimage_sources(crops: int) -> Iterator[tuple[str, str, np.ndarray, int]]:
    """Yield (class, name, RGB image, patch count) of scikit-image's ground photos."""
    for name in SKIMAGE_CLASSES:
        grey = getattr(data, name)()
        yield name, name, np.repeat(grey[..., None], 3, axis=2), crops


def indoor_sources(
    root: Path, photos: int, crops: int, rng: np.random.Generator
) -> Iterator[tuple[str, str, np.ndarray, int]]:
    """Yield (class, photo stem, RGB image, patch count) of ``photos`` seeded photos per class."""
    scan = scan_image_folder(root)
    labels = np.asarray(scan.labels)
    for label in sorted(set(scan.labels)):
        paths = [scan.paths[i] for i in np.flatnonzero(labels == label)]
        for i in sorted(rng.choice(len(paths), size=min(photos, len(paths)), replace=False)):
            yield label, paths[i].stem, read_image_rgb(paths[i]), crops


def build_patches(
    out: Path,
    source: str,
    *,
    photos: int = 240,
    crops: int = 1,
    size: int = 64,
    seed: int = SEED,
    indoor: Path = INDOOR,
) -> dict[str, int]:
    """Write a labelled folder ``out/<class>/<name>_<i>.png`` of patches; return the count per class.

    Refuses a folder inside the repository (the shared photos must not be
    copied into it).
    """
    out = out.resolve()
    if out.is_relative_to(REPO):
        raise ValueError(f"{out}: the patches must not be written inside the repository")
    rng = np.random.default_rng(seed)
    if source == "skimage":
        sources = skimage_sources(crops)
    else:
        sources = indoor_sources(indoor, photos, crops, rng)
    counts: dict[str, int] = {}
    for label, name, image, count in sources:
        (out / label).mkdir(parents=True, exist_ok=True)
        for i, patch in enumerate(random_crops(image, count, size, rng)):
            cv2.imwrite(str(out / label / f"{name}_{i:03d}.png"), patch[..., ::-1])
        counts[label] = counts.get(label, 0) + count
    return counts


def print_report(report: AccuracyReport) -> None:
    """Print untuned and tuned (nested) accuracies and each outer fold's choice."""
    rows = [("untuned defaults", report.chosen), ("paper recipe", report.paper)]
    if report.tuned is not None:
        rows.append(("tuned (nested)", report.tuned.cross_validation))
    classes = report.chosen.classes
    print(f"{'':18s}" + "".join(f"{c:>9s}" for c in classes) + f"{'mean':>9s}")
    for name, cv in rows:
        cells = "".join(f"{cv.per_class_accuracy[c]:9.1f}" for c in classes)
        print(f"{name:18s}{cells}{cv.mean_accuracy:9.1f}")
    if report.tuned is None:
        return
    print("choices per outer fold (inner mean % / fold accuracy %):")
    for fold in report.tuned.folds:
        inner = 100.0 * float(fold.search.mean_score[fold.search.best])
        print(f"  {fold.search.choice}  {inner:.1f} / {fold.accuracy:.1f}")


def main() -> None:
    """Build the patches, score them untuned and tuned, print the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source", choices=("indoor", "skimage"), default="indoor")
    parser.add_argument("--photos", type=int, default=240, help="indoor photos per class")
    parser.add_argument(
        "--crops", type=int, default=1, help="patches per photo (skimage: per class)"
    )
    parser.add_argument("--size", type=int, default=64, help="patch side, px")
    parser.add_argument("--grid", type=Path, help="grid YAML (default: the default grid)")
    parser.add_argument("--out", type=Path, help="patch folder (default: temporary)")
    parser.add_argument("--jobs", type=int, default=1)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        out = args.out if args.out is not None else Path(tmp) / "patches"
        counts = build_patches(
            out, args.source, photos=args.photos, crops=args.crops, size=args.size
        )
        print(f"{sum(counts.values())} patches of {args.size} px in {out}: {counts}")
        print(f"load average before: {os.getloadavg()[0]:.1f}")
        begin = time.perf_counter()
        report = report_accuracy(
            out, tune=True, grid_path=args.grid, jobs=args.jobs, progress=False
        )
        elapsed = time.perf_counter() - begin
    print_report(report)
    print(f"report accuracy --tune: {elapsed:.0f} s; load average after: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
