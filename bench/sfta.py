"""Speed of the SFTA features (Chen eq. 18-21) on one core, against JPEG decoding.

Times ``sfta_features`` (n_t = 4, 24 values) on a 640x480 RGB frame made from
a real photo (skimage's grass or gravel texture resized with cv2.resize) and
on a 160x120 crop of it (a view, as a region of interest would be), taking
turns in blocks of calls with ``cv2.imdecode`` of the same image encoded once
as JPEG (OpenCV's default quality 95, as camera frames are stored).
Prints median and minimum over many repeats, the ratio SFTA / decode of the
medians (target <= 0.5 at 640x480), and the thresholds
alone against ``skimage.filters.threshold_multiotsu``. OpenCV is pinned to one
thread. Other jobs on the machine slow the medians: the load average is
printed before and after.

Usage::

    python bench/sfta.py [--image grass|gravel] [--repeat 1000]
"""

from __future__ import annotations

import argparse
import os
import time
from functools import partial

import cv2
import numpy as np
from skimage import data
from skimage.filters import threshold_multiotsu

from terrain_odom.vision.sfta import multiotsu_thresholds, sfta_features


def timings(fns, repeat, warmup=10, block=50):
    """Seconds of each of `repeat` calls of each function.

    The functions take turns in blocks of `block` calls, so that they share
    whatever load the machine has while each runs with warm caches.
    Returns an array of shape (len(fns), repeat).
    """
    times = np.empty((len(fns), repeat))
    for fn in fns:
        for _ in range(warmup):
            fn()
    for start in range(0, repeat, block):
        for j, fn in enumerate(fns):
            for i in range(start, min(start + block, repeat)):
                begin = time.perf_counter()
                fn()
                times[j, i] = time.perf_counter() - begin
    return times


def frame_from(name):
    grey = cv2.resize(getattr(data, name)(), (640, 480), interpolation=cv2.INTER_LINEAR)
    return cv2.cvtColor(grey, cv2.COLOR_GRAY2RGB)


def row(label, times, reference=None):
    text = f"{label:36s} median {np.median(times) * 1e3:8.3f} ms   min {times.min() * 1e3:8.3f} ms"
    if reference is not None:
        text += f"   SFTA / decode {np.median(times) / np.median(reference):5.2f}"
    print(text)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--image", choices=("grass", "gravel"), default="grass")
    parser.add_argument("--repeat", type=int, default=1000)
    args = parser.parse_args()
    cv2.setNumThreads(1)
    frame = frame_from(args.image)
    crop = frame[180:300, 240:400]
    jpeg = cv2.imencode(".jpg", cv2.cvtColor(frame, cv2.COLOR_RGB2BGR))[1]
    crop_jpeg = cv2.imencode(".jpg", cv2.cvtColor(crop, cv2.COLOR_RGB2BGR))[1]
    hist = np.bincount(cv2.cvtColor(frame, cv2.COLOR_RGB2GRAY).ravel(), minlength=256)

    print(f"skimage {args.image} as a 640x480 RGB frame; load average {os.getloadavg()}")
    print(f"{args.repeat} repeats, one OpenCV thread")
    sfta_features(frame)  # the compiled kernels loaded (or compiled, the first time)
    for label, image, encoded in (("640x480", frame, jpeg), ("160x120 crop", crop, crop_jpeg)):
        decode, sfta = timings(
            [partial(cv2.imdecode, encoded, cv2.IMREAD_COLOR), partial(sfta_features, image)],
            args.repeat,
        )
        row(f"JPEG decode {label} ({encoded.size / 1024:.0f} KiB)", decode)
        row(f"sfta_features {label}", sfta, decode)

    print("thresholds of the frame's histogram:")
    for n_t in (2, 3, 4):
        (ours,) = timings([partial(multiotsu_thresholds, hist, n_t)], 200)
        row(f"  multiotsu_thresholds n_t={n_t}", ours)
    grey = cv2.cvtColor(frame, cv2.COLOR_RGB2GRAY)
    for n_t, repeat in ((2, 20), (3, 3), (4, 1)):
        (theirs,) = timings([partial(threshold_multiotsu, grey, classes=n_t + 1)], repeat, 0)
        row(f"  skimage threshold_multiotsu n_t={n_t}", theirs)
    print(f"load average {os.getloadavg()}")


if __name__ == "__main__":
    main()
