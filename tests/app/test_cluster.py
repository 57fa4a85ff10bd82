"""Tests of :mod:`terrain_odom.app.cluster` and of the subcommands it runs on a Dask cluster.

The identity tests run each workflow once in this process (joblib as
without ``--dask``) and once on a real Dask scheduler with two workers on
loopback (a ``LocalCluster`` of threads, reached by its address as a remote
scheduler would be), and require the same result: same accuracy, same
parameters, same order. ``test_cluster_processes.py`` starts real
``dask scheduler`` / ``dask worker`` processes.
"""

from __future__ import annotations

import dataclasses
import math
import os
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
import skimage.data

from terrain_odom.app import cluster as cluster_module
from terrain_odom.app.cluster import (
    ClusterSpec,
    dask_cluster,
    parse_dask_address,
    run_jobs,
)
from terrain_odom.app.evaluate import evaluate, evaluate_logs
from terrain_odom.app.fit import compare
from terrain_odom.app.simulate import SimOutput
from terrain_odom.app.train import report_accuracy, train
from terrain_odom.config.classifier import ClassifierConfig
from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.fitting import FitOptions
from terrain_odom.io.classifier_file import load_tuning

distributed = pytest.importorskip("distributed")

FAST = FitOptions(popsize=6, maxiter=8, seed=1)
GRID = "k: [1, 3]\nweights: [uniform, distance]\n"


def _pid(_: int) -> int:
    return os.getpid()


def _where(item: int, *, offset: np.ndarray) -> tuple[int, str]:
    return item + int(offset.sum()), distributed.get_worker().address


def test_parse_dask_address() -> None:
    assert parse_dask_address("local:3") == ClusterSpec(None, 3)
    assert parse_dask_address("tcp://10.0.0.5:8786") == ClusterSpec("tcp://10.0.0.5:8786")
    for bad in (
        "local:0",
        "local:x",
        "local:",
        "10.0.0.5:8786",
        "http://h:1",
        "tcp://",
        "tcp://a b",
    ):
        with pytest.raises(ConfigError, match="--dask"):
            parse_dask_address(bad)


def test_without_an_address_nothing_changes() -> None:
    with dask_cluster(None) as cluster:
        assert cluster is None
        assert run_jobs(_pid, [1, 2], cluster) == [os.getpid()] * 2  # in this process


def test_without_dask_installed_one_line_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed fails
    with pytest.raises(ConfigError, match=r"pip install 'terrain-odom\[dask\]'"):
        with dask_cluster("local:1"):
            pass


def test_no_scheduler_one_line_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(cluster_module, "CONNECT_TIMEOUT", 0.5)
    port = _free_port()
    with pytest.raises(ConfigError, match=f"no Dask scheduler answers at tcp://127.0.0.1:{port}"):
        with dask_cluster(f"tcp://127.0.0.1:{port}"):
            pass


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_jobs_run_on_the_workers_in_input_order(scheduler: str) -> None:
    with dask_cluster(scheduler) as cluster:
        assert cluster is not None and cluster.threads == 2 and cluster.jobs == 2
        done = run_jobs(_where, list(range(12)), cluster, offset=np.ones(100_000))
    assert [item for item, _ in done] == list(range(100_000, 100_012))
    assert {worker for _, worker in done} <= set(_workers(scheduler)) and len(done) == 12


def _workers(address: str) -> list[str]:
    with distributed.Client(address) as client:
        return list(client.nthreads())


def _process(_: int) -> tuple[int, str | None, str | None]:
    return os.getpid(), os.environ.get("MALLOC_TRIM_THRESHOLD_"), os.environ.get("OMP_NUM_THREADS")


def test_local_cluster_starts_and_stops_worker_processes() -> None:
    with dask_cluster("local:2") as cluster:
        assert cluster is not None and cluster.threads == 2
        seen = run_jobs(_process, list(range(8)), cluster)
    pids = {pid for pid, _, _ in seen}
    assert os.getpid() not in pids and len(pids) <= 2
    # one BLAS thread per worker (dask's default), glibc's malloc left as it is (not dask's)
    assert {(trim, omp) for _, trim, omp in seen} == {(None, "1")}


def test_compare_on_the_cluster_is_the_same(sim_output: SimOutput, scheduler: str) -> None:
    args = dict(models=["idd", "edd-sym", "icr"], horizon="1m", options=FAST)
    here = compare([sim_output.log_csv], [sim_output.log_csv], **args)
    there = compare([sim_output.log_csv], [sim_output.log_csv], dask=scheduler, **args)
    assert list(there.models) == list(here.models) == ["idd", "edd-sym", "icr"]
    for name, mine in here.models.items():
        theirs = there.models[name]
        assert theirs.errors == mine.errors and theirs.skipped == mine.skipped
        assert {k: s.params for k, s in theirs.params.sets.items()} == {
            k: s.params for k, s in mine.params.sets.items()
        }
    assert here.models["edd-sym"].params.sets["*"].params != {}  # fitted, not empty


def test_evaluate_logs_pools_the_logs_and_matches_evaluate(
    sim_output: SimOutput, tmp_path: Path, scheduler: str
) -> None:
    logs = [sim_output.log_csv, sim_output.log_csv]
    batch = evaluate_logs(logs, horizon=1.0, out_dir=tmp_path / "ev")
    single = evaluate(None, sim_output.log_csv, horizon=1.0)
    assert [r.to_dict() for r in batch.logs] == [single.to_dict()] * 2
    (name,) = batch.pooled
    pooled = batch.pooled[name]
    assert pooled.errors.translation.count == 2 * single.windows
    assert pooled.errors.translation.median == single.models[name].errors.translation.median
    assert math.isclose(pooled.ate_rmse, single.models[name].ate.rmse, rel_tol=1e-12)
    assert [p.name for p in batch.outputs] == ["evaluation.json", "evaluation.md"]
    on_cluster = evaluate_logs(logs, horizon=1.0, dask=scheduler)
    assert on_cluster.to_dict() == batch.to_dict() and on_cluster.markdown() == batch.markdown()


def test_pooled_ate_weights_each_log_by_its_rows(sim_output: SimOutput, tmp_path: Path) -> None:
    log = sim_output.log_csv
    short = tmp_path / "short.csv"
    lines = log.read_text(encoding="utf-8").splitlines()
    short.write_text("\n".join(lines[: len(lines) // 2]) + "\n", encoding="utf-8")
    batch = evaluate_logs([log, short], horizon=1.0)
    (name,) = batch.pooled
    a, b = (r.models[name].ate for r in batch.logs)
    expected = math.sqrt((a.count * a.rmse**2 + b.count * b.rmse**2) / (a.count + b.count))
    assert a.count > b.count > 0 and a.rmse != b.rmse
    assert math.isclose(batch.pooled[name].ate_rmse, expected, rel_tol=1e-12)
    assert batch.pooled[name].ate_count == a.count + b.count


def texture_folder(root: Path, per_class: int = 8) -> Path:
    """``brick/`` and ``grass/``: 48-px crops of two skimage textures (PNG)."""
    for name, image in (("brick", skimage.data.brick()), ("grass", skimage.data.grass())):
        (root / name).mkdir(parents=True)
        for i in range(per_class):
            crop = image[(i // 4) * 48 : (i // 4 + 1) * 48, (i % 4) * 48 : (i % 4 + 1) * 48]
            assert cv2.imwrite(str(root / name / f"{i}.png"), np.clip(crop, 30, 220))
    return root


@pytest.fixture(scope="module")
def images(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    root = tmp_path_factory.mktemp("textures")
    grid = root / "grid.yaml"
    grid.write_text(GRID, encoding="utf-8")
    return texture_folder(root / "images"), grid


def test_report_accuracy_tuned_on_the_cluster_is_the_same(
    images: tuple[Path, Path], scheduler: str
) -> None:
    folder, grid = images
    cfg = ClassifierConfig(n_t=1)
    args = dict(folds=3, progress=False, grid_path=grid)
    here = report_accuracy(folder, cfg, jobs=1, **args)
    there = report_accuracy(folder, cfg, dask=scheduler, **args)
    for name, cv in here.configurations():
        assert np.array_equal(dict(there.configurations())[name].confusion, cv.confusion), name
    assert here.tuned is not None and there.tuned is not None
    assert [f.search.choice for f in there.tuned.folds] == [
        f.search.choice for f in here.tuned.folds
    ]
    assert [f.predicted.tolist() for f in there.tuned.folds] == [
        f.predicted.tolist() for f in here.tuned.folds
    ]
    assert here.chosen.mean_accuracy > 50.0  # the two textures are told apart


def test_train_tuned_on_the_cluster_is_the_same(
    images: tuple[Path, Path], tmp_path: Path, scheduler: str
) -> None:
    folder, grid = images
    cfg = ClassifierConfig(n_t=1)
    here = train(folder, tmp_path / "a", cfg, folds=3, jobs=1, progress=False, grid_path=grid)
    there = train(
        folder, tmp_path / "b", cfg, folds=3, progress=False, grid_path=grid, dask=scheduler
    )
    assert there.config == here.config and there.counts == here.counts
    assert here.cross_validation is not None and there.cross_validation is not None
    assert np.array_equal(there.cross_validation.confusion, here.cross_validation.confusion)
    mine, theirs = load_tuning(here.classifier_path), load_tuning(there.classifier_path)
    assert mine is not None and theirs == mine
    assert dataclasses.asdict(there.config) == mine["chosen_config"]


def test_real_logs_batch_on_the_cluster(drive_dir: Path, warthog_yaml: Path, scheduler: str):
    """Two real Warthog grass runs: the same per-log and pooled figures on the cluster."""
    from terrain_odom.config import load_config

    logs = [drive_dir / f"warthog_wheels_grass_2024_7_29_{t}.csv" for t in ("14h4s53", "14h8s51")]
    cfg = load_config(warthog_yaml)
    here = evaluate_logs(logs, config=cfg)
    there = evaluate_logs(logs, config=cfg, dask=scheduler)
    assert there.to_dict() == here.to_dict()
    # the pooled figures are every log's windows together (not figures copied from a run)
    name = "idd (B=1.08 m)"
    pooled = here.pooled[name].errors.translation
    per_log = [r.models[name].windows for r in here.logs]
    assert [w.translation.size for w in per_log] == [r.windows for r in here.logs]
    assert min(r.windows for r in here.logs) > 100  # minutes of driving each
    assert pooled.count == sum(r.windows for r in here.logs)
    together = np.concatenate([w.translation_per_m for w in per_log])
    assert pooled.median == np.median(together) and pooled.mean == pytest.approx(together.mean())


def test_real_photos_accuracy_on_the_cluster(indoor_dir: Path, tmp_path: Path, scheduler: str):
    """A few real floor photos per class: the same confusion matrices on the cluster."""
    for folder in sorted(p for p in indoor_dir.iterdir() if p.is_dir()):
        (tmp_path / folder.name).mkdir()
        for photo in sorted(folder.glob("*.jpg"))[:6]:
            os.symlink(photo, tmp_path / folder.name / photo.name)
    here = report_accuracy(tmp_path, folds=3, jobs=1, progress=False)
    there = report_accuracy(tmp_path, folds=3, progress=False, dask=scheduler)
    assert here.counts == {"carpet": 6, "tiles": 6, "wood": 6}
    for (name, mine), (_, theirs) in zip(
        here.configurations(), there.configurations(), strict=True
    ):
        assert np.array_equal(theirs.confusion, mine.confusion), name


def test_scheduler_without_workers_one_line_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(cluster_module, "CONNECT_TIMEOUT", 0.5)
    with distributed.LocalCluster(n_workers=0, processes=False, dashboard_address=":0") as empty:
        with pytest.raises(ConfigError, match="has no worker"):
            with dask_cluster(empty.scheduler_address):
                pass


def test_an_error_on_a_worker_is_the_projects_own(
    sim_output: SimOutput, tmp_path: Path, scheduler: str
) -> None:
    short = tmp_path / "short.csv"
    lines = sim_output.log_csv.read_text(encoding="utf-8").splitlines()
    short.write_text("\n".join(lines[:4]) + "\n", encoding="utf-8")
    with pytest.raises(InputFileError, match="short.csv: no 1.0 m window"):
        evaluate_logs([sim_output.log_csv, short], horizon=1.0, dask=scheduler)
