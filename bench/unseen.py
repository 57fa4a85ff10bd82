"""Unknown ground: how often frames of a class never trained on confirm a terrain change.

Leave one class out: the classifier is trained as ``terrain-odom train`` trains
it (``min_tile_size`` from the images' size, cross-validated confidence
threshold, unknown-ground distance) on the other classes, and the left-out
class's images are fed, in a seeded random order, as camera frames to the
terrain tracker (``confirm: 2``, the default), which starts on each trained
class in turn. Printed per left-out class: the share of its frames that
confirm a terrain change and the share of the streams (a starting class and
a seeded order) in which any change is confirmed, with the classifier as it
was before the threshold and the unknown-ground distance (every labelled
frame a sighting) and as it is now; and, for the trained classes, the share of their held-out frames
(5-fold cross-validation) that remain sightings and are right.

Data sets (``--set``): ``floor64`` (64x64 patches of the floor photos, one
per photo, 240 photos per class), ``skimage64`` (80 patches 64x64 of each of
scikit-image's grass, gravel, brick), ``floor`` (the floor photos, ``--photos``
per class).

Usage::

    python bench/unseen.py [--set floor64|skimage64|floor] [--photos 200] [--features sfta+lbp+lab]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from families import subset  # noqa: E402
from small_patches import INDOOR, build_patches  # noqa: E402

from terrain_odom.config.classifier import ClassifierConfig  # noqa: E402
from terrain_odom.estimation.terrain import TerrainTracker  # noqa: E402
from terrain_odom.io.images import median_short_side, read_image_rgb, scan_image_folder  # noqa: E402
from terrain_odom.vision.classifier import TerrainClassifier  # noqa: E402
from terrain_odom.vision.cross_validation import cross_validate_images, stratified_folds  # noqa: E402
from terrain_odom.vision.dataset import LabelledFeatures, extract_features  # noqa: E402
from terrain_odom.vision.features import resolve_scale  # noqa: E402

CONFIRM = 2


def trained(data: LabelledFeatures, calibrated: bool) -> TerrainClassifier:
    """Return a classifier fitted on ``data`` as ``train`` fits it (or as before: no threshold, no novelty)."""
    model = TerrainClassifier(data.config).fit(data.features, data.labels, data.region)
    if calibrated:
        model.calibrate_novelty()
        threshold = cross_validate_images(data, folds=min(5, *data.counts().values())).threshold()
        model.min_confidence = 0.0 if threshold is None else threshold
    return model


def sightings(model: TerrainClassifier, data: LabelledFeatures) -> tuple[np.ndarray, np.ndarray]:
    """Label of each image and whether it is a sighting for the tracker."""
    labels, confidence = model.predict_with_confidence(data.features, data.region)
    return labels, (confidence > 0) & (confidence >= model.sighting_threshold)


def flips(labels: np.ndarray, seen: np.ndarray, start: str, seed: int) -> int:
    """Count the changes the tracker confirms on the frames in a seeded order, starting on ``start``."""
    order = np.random.default_rng(seed).permutation(labels.size)
    tracker = TerrainTracker(CONFIRM)
    tracker.observe(start)
    return sum(tracker.observe(labels[i]) is not None for i in order if seen[i])


def known_frames(data: LabelledFeatures) -> tuple[float, float]:
    """Held-out frames of the trained classes (5-fold): share still sightings, share of those right."""
    kept = right = 0
    for train_idx, test_idx in stratified_folds(5).split(
        np.zeros((data.labels.size, 1)), data.labels
    ):
        test = data.select(test_idx)
        labels, seen = sightings(trained(data.select(train_idx), True), test)
        kept += int(seen.sum())
        right += int((seen & (labels == test.labels)).sum())
    return 100.0 * kept / data.labels.size, 100.0 * right / max(kept, 1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", choices=("floor64", "skimage64", "floor"), default="floor64")
    parser.add_argument("--photos", type=int, default=200, help="floor photos per class")
    parser.add_argument("--features", default=ClassifierConfig().features)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    print(f"load average before: {os.getloadavg()[0]:.1f}")
    with tempfile.TemporaryDirectory() as tmp:
        if args.set == "floor":
            images = subset(scan_image_folder(INDOOR), args.photos)
        else:
            folder = Path(tmp) / args.set
            source = "indoor" if args.set == "floor64" else "skimage"
            build_patches(folder, source, crops=1 if source == "indoor" else 80)
            images = scan_image_folder(folder)
        cfg = resolve_scale(
            ClassifierConfig(features=args.features), median_short_side(images.paths)
        )
        data = extract_features(images, cfg, read=read_image_rgb, jobs=args.jobs, progress=False)
    print(
        f"{args.set}: {data.labels.size} images, features {cfg.features}, "
        f"min_tile_size {cfg.min_tile_size}, confirm {CONFIRM}"
    )
    print(
        f"{'left out':10s} {'frames':>6s} {'frames confirming a change, % before / now':>44s} "
        f"{'streams flipped, % before / now':>32s} {'trained: kept %':>16s} {'right %':>8s} "
        f"{'threshold':>9s}"
    )
    for unseen in data.classes:
        known = data.select(np.flatnonzero(data.labels != unseen))
        known = LabelledFeatures(
            **{**known.__dict__, "classes": tuple(c for c in data.classes if c != unseen)}
        )
        frames = data.select(np.flatnonzero(data.labels == unseen))
        share, flipped = {}, {}
        for calibrated in (False, True):
            model = trained(known, calibrated)
            labels, seen = sightings(model, frames)
            counts = [
                flips(labels, seen, start, seed) for start in known.classes for seed in range(5)
            ]
            share[calibrated] = 100.0 * np.mean(counts) / frames.labels.size
            flipped[calibrated] = 100.0 * np.mean(np.array(counts) > 0)
        kept, right = known_frames(known)
        print(
            f"{unseen:10s} {frames.labels.size:6d} {share[False]:36.1f} / {share[True]:5.1f} "
            f"{flipped[False]:24.1f} / {flipped[True]:5.1f} {kept:16.1f} {right:8.1f} "
            f"{model.min_confidence:9.2f}"
        )
    print(f"load average after: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
