"""Texture families alone and combined: cross-validated accuracy and time per 640x480 frame.

For each data set and each ``features`` setting, the mean per-class accuracy
of 5-fold stratified cross-validation over images (the untuned defaults
otherwise, ``min_tile_size: auto`` resolved from the images' size, as
``report accuracy`` does) and the feature time of one 640x480 frame (a real
floor photo resized; median of ``--repeat`` calls on one core, one OpenCV
thread; CPU time, which other jobs on the machine do not inflate as they
inflate wall time) cut into the 4x4 tiles the defaults give it, beside the
JPEG decoding of the same frame.

Data sets (``--sets``):

* ``floor``: the floor photos of ``../shared/data/indoor_surface`` (carpet,
  tiles, wood; ``--photos`` per class, seeded subset; 0 = all 1,774);
* ``floor64``: 64x64 patches of them, one per photo, 240 photos per class
  (``bench/small_patches.py``'s folder);
* ``skimage64``: 80 patches 64x64 of each of scikit-image's ``grass()``,
  ``gravel()``, ``brick()``.

Usage::

    python bench/families.py [--sets floor floor64 skimage64] [--photos 0]
        [--features sfta+lab lbp ...] [--jobs 2] [--repeat 30]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from small_patches import INDOOR, build_patches  # noqa: E402

from terrain_odom.config.classifier import ClassifierConfig, paper_config  # noqa: E402
from terrain_odom.io.images import median_short_side, read_image_rgb, scan_image_folder  # noqa: E402
from terrain_odom.vision.cross_validation import cross_validate_images  # noqa: E402
from terrain_odom.vision.dataset import LabelledImages, extract_feature_sets  # noqa: E402
from terrain_odom.vision.features import image_features, resolve_scale  # noqa: E402

FEATURES = (
    "sfta",
    "sfta+lab",
    "lbp",
    "glcm",
    "lbp+lab",
    "glcm+lab",
    "sfta+lbp+lab",
    "sfta+glcm+lab",
    "lbp+glcm+lab",
    "sfta+lbp+glcm+lab",
)
PAPER = "paper (Chen)"


def subset(images: LabelledImages, per_class: int, seed: int = 0) -> LabelledImages:
    """Return a seeded subset of ``per_class`` images of each class (all with 0)."""
    if per_class <= 0:
        return images
    rng = np.random.default_rng(seed)
    labels = np.asarray(images.labels)
    keep: list[int] = []
    for name in images.classes:
        index = np.flatnonzero(labels == name)
        keep += sorted(rng.choice(index, size=min(per_class, index.size), replace=False).tolist())
    return LabelledImages(
        images.root,
        images.classes,
        tuple(images.paths[i] for i in keep),
        tuple(images.labels[i] for i in keep),
    )


def median_ms(fn, repeat: int) -> float:
    """Median CPU time of ``fn()`` over ``repeat`` calls after 3 warm-up calls, ms.

    CPU time of this process (``time.process_time``), not wall time: on a
    machine shared with other jobs a call's wall time includes the time it
    waited for a core.
    """
    for _ in range(3):
        fn()
    times = []
    for _ in range(repeat):
        begin = time.process_time()
        fn()
        times.append(time.process_time() - begin)
    return 1e3 * float(np.median(times))


def frame_ms(cfg: ClassifierConfig, frame: np.ndarray, repeat: int) -> float:
    """Median feature time of a 640x480 frame, ms (4x4 tiles, as a model of 64-px patches cuts it)."""
    if cfg.tiles > 1:
        cfg = dataclasses.replace(cfg, min_tile_size=16)
    return median_ms(lambda: image_features(frame, cfg), repeat)


def score(folder: Path, features: list[str], photos: int, jobs: int) -> tuple[dict, int, float]:
    """Mean per-class accuracy of each setting (and Chen's recipe); images and short side."""
    images = subset(scan_image_folder(folder), photos)
    short = median_short_side(images.paths)
    configs = [resolve_scale(ClassifierConfig(features=f), short) for f in features]
    configs.append(paper_config())
    sets = extract_feature_sets(images, configs, read=read_image_rgb, jobs=jobs, progress=False)
    out = {}
    for name, data in zip([*features, PAPER], sets, strict=True):
        cv = cross_validate_images(data, folds=5)
        out[name] = (cv.mean_accuracy, cv.worst_class())
    return out, len(images.paths), short


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sets", nargs="*", default=["floor", "floor64", "skimage64"])
    parser.add_argument("--photos", type=int, default=0, help="floor photos per class (0: all)")
    parser.add_argument("--features", nargs="+", default=list(FEATURES))
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--repeat", type=int, default=30)
    args = parser.parse_args()
    cv2.setNumThreads(1)
    print(f"load average before: {os.getloadavg()[0]:.1f}")
    photo = read_image_rgb(sorted((INDOOR / "carpet").glob("*.jpg"))[0])
    frame = cv2.resize(photo, (640, 480), interpolation=cv2.INTER_LINEAR)
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.sets:
            begin = time.perf_counter()
            if name == "floor":
                folder, photos = INDOOR, args.photos
            else:
                folder, photos = Path(tmp) / name, 0
                source = "indoor" if name == "floor64" else "skimage"
                build_patches(folder, source, crops=1 if source == "indoor" else 80)
            results[name], n, short = score(folder, args.features, photos, args.jobs)
            print(
                f"{name}: {n} images, shorter side {short:.0f} px, {time.perf_counter() - begin:.0f} s"
            )
    jpeg = cv2.imencode(".jpg", cv2.cvtColor(frame, cv2.COLOR_RGB2BGR))[1]
    decode = median_ms(lambda: cv2.imdecode(jpeg, cv2.IMREAD_COLOR), args.repeat)
    timing = {f: frame_ms(ClassifierConfig(features=f), frame, args.repeat) for f in args.features}
    timing[PAPER] = frame_ms(paper_config(), frame, args.repeat)
    print(f"JPEG decode of the 640x480 frame: {decode:.2f} ms (median, same run)")
    header = f"{'features':20s}" + "".join(f"{s:>22s}" for s in args.sets)
    print(header + f"{'ms/640x480':>12s}{'x decode':>9s}")
    for f in [*args.features, PAPER]:
        cells = ""
        for s in args.sets:
            mean, (worst, worst_pc) = results[s][f]
            cells += f"{mean:8.1f} ({worst[:6]:>6s} {worst_pc:4.1f})"
        print(f"{f:20s}{cells}{timing[f]:12.2f}{timing[f] / decode:9.2f}")
    print(f"load average after: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
