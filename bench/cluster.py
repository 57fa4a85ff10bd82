"""``--dask``: the indoor accuracy report and a 10-log compare on 1 vs 2 Dask workers.

Prints every figure of docs/results/cluster.md. Each workload runs five
times in this one process: without ``--dask`` (the baseline: feature
extraction in ``--jobs 1``, ``compare``'s models one after the other); cold
on ``--dask local:1`` and ``--dask local:2`` (local clusters of 1 and 2
worker processes, one thread each, started and stopped inside the timing);
warm on an already running local cluster of 1 and 2 workers that have
imported terrain-odom, reached by its ``tcp://`` address (as a long-running
cluster is). It prints the wall times, the ratios 1 worker / 2 workers, and
whether every run gave the same result (the same confusion matrices; the
same parameters and held-out errors).

1. ``report accuracy`` on a subset of the indoor floor photos
   (``--per-class`` images of each of carpet, tiles and wood, the first in
   name order; the full 1,774 photos take too long on a shared machine);
2. ``compare`` of every model on 10 real Warthog logs (the six
   ``warthog_wheels_*.csv`` of ``../shared/data/drive`` cycled to 10),
   trained and evaluated on them, with a short optimiser (``--popsize``,
   ``--maxiter``: a subset of the default 15 x 300 work).

Usage::

    python bench/cluster.py [--data ../shared/data] [--per-class 200] [--popsize 5] [--maxiter 6]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from collections.abc import Callable
from itertools import cycle, islice
from pathlib import Path
from typing import Any

from terrain_odom.app.cluster import dask_cluster
from terrain_odom.app.fit import CompareReport, compare
from terrain_odom.app.train import AccuracyReport, report_accuracy
from terrain_odom.config import load_config
from terrain_odom.fitting import FitOptions
from terrain_odom.fitting.params import ANY_TERRAIN

REPO = Path(__file__).resolve().parents[1]
WORKERS = (1, 2)


def subset_folder(images: Path, per_class: int, root: Path) -> Path:
    """Link the first ``per_class`` photos of each class into ``root`` (no copy)."""
    for folder in sorted(p for p in images.iterdir() if p.is_dir()):
        (root / folder.name).mkdir(parents=True)
        for photo in sorted(folder.glob("*.jpg"))[:per_class]:
            os.symlink(photo, root / folder.name / photo.name)
    return root


def _warm() -> None:
    import terrain_odom.app.evaluate  # noqa: F401  (what the tasks import)
    import terrain_odom.vision.dataset  # noqa: F401


def _clock(run: Callable[[str | None], Any], dask: str | None) -> tuple[float, Any]:
    start = time.perf_counter()
    result = run(dask)
    return time.perf_counter() - start, result


def timed(run: Callable[[str | None], Any]) -> dict[str, tuple[float, Any]]:
    """Wall time, s, and result of ``run(dask)``: baseline, then cold and warm per worker count.

    Cold: ``--dask local:N`` (starting the cluster is part of the time).
    Warm: an already running cluster of ``N`` workers that have imported
    terrain-odom, reached by its address (what a long-running cluster is).
    """
    from distributed import Client

    out = {"baseline": _clock(run, None)}
    for n in WORKERS:
        out[f"cold local:{n}"] = _clock(run, f"local:{n}")
        with dask_cluster(f"local:{n}") as cluster:
            assert cluster is not None
            with Client(cluster.address) as client:
                client.run(_warm)
            out[f"warm {n} worker(s)"] = _clock(run, cluster.address)
    return out


def accuracy_key(report: AccuracyReport) -> list[list[list[int]]]:
    return [cv.confusion.tolist() for _, cv in report.configurations()]


def compare_key(report: CompareReport) -> list[Any]:
    return [
        (name, {k: s.params for k, s in m.params.sets.items()}, m.to_dict()["errors"])
        for name, m in report.models.items()
    ]


def show(title: str, runs: dict[str, tuple[float, Any]], key: Callable[[Any], Any]) -> None:
    same = all(key(result) == key(runs["baseline"][1]) for _, result in runs.values())
    print(f"\n{title}")
    for name, (seconds, _) in runs.items():
        print(f"  {name:<18} {seconds:7.1f} s")
    cold = runs["cold local:1"][0] / runs["cold local:2"][0]
    warm = runs["warm 1 worker(s)"][0] / runs["warm 2 worker(s)"][0]
    print(f"  1 worker / 2 workers: cold {cold:.2f}x, warm {warm:.2f}x; identical results: {same}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=REPO.parent / "shared" / "data")
    parser.add_argument("--per-class", type=int, default=200)
    parser.add_argument("--popsize", type=int, default=5)
    parser.add_argument("--maxiter", type=int, default=6)
    args = parser.parse_args()
    print(f"cores usable: {len(os.sched_getaffinity(0))}, load average {os.getloadavg()[0]:.1f}")
    with tempfile.TemporaryDirectory() as tmp:
        images = subset_folder(args.data / "indoor_surface", args.per_class, Path(tmp))
        runs = timed(lambda dask: report_accuracy(images, jobs=1, progress=False, dask=dask))
        counts = runs["baseline"][1].counts
        show(f"report accuracy, indoor subset {counts}", runs, accuracy_key)
        print(f"  mean accuracy (chosen): {runs['baseline'][1].chosen.mean_accuracy:.1f} %")
    logs = list(islice(cycle(sorted((args.data / "drive").glob("warthog_wheels_*.csv"))), 10))
    cfg = load_config(REPO / "config" / "warthog.yaml")
    options = FitOptions(popsize=args.popsize, maxiter=args.maxiter, seed=0)
    runs = timed(lambda dask: compare(logs, logs, options=options, config=cfg, dask=dask))
    show(
        f"compare, {len(runs['baseline'][1].models)} models, 10 logs "
        f"(popsize {args.popsize}, maxiter {args.maxiter})",
        runs,
        compare_key,
    )
    fitted = runs["baseline"][1].models["edd-asym"].errors[ANY_TERRAIN].translation
    print(f"  edd-asym held-out median: {fitted.median:.4f} m/m over {fitted.count} windows")
    print(f"load average at the end: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
