"""``terrain-odom run --record``: OUT/run.rrd, read back by rerun; a clear error without rerun."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from rerun.chunk import RrdReader

from terrain_odom.app.record import NEEDS_RERUN
from terrain_odom.cli.main import main

SRC = Path(__file__).resolve().parents[2] / "src"


def _temporal_rows(path: Path) -> tuple[Counter[str], list[tuple[float, list[float]]]]:
    """Rows on the timeline per entity, and the ``(t, centre)`` of every region of interest."""
    rows: Counter[str] = Counter()
    centres = []
    for chunk in RrdReader(path).stream():
        if chunk.is_static:
            continue
        rows[chunk.entity_path] += chunk.num_rows
        batch = chunk.to_record_batch()
        if chunk.entity_path == "/camera/roi" and "Boxes2D:centers" in batch.schema.names:
            stamps = batch.column("t").to_pylist()
            values = batch.column("Boxes2D:centers").to_pylist()
            centres += [(d.total_seconds(), v[0]) for d, v in zip(stamps, values, strict=True)]
    return rows, sorted(centres)


def _csv_rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def test_a_camera_run_records_every_frame_row_and_region(sample_dir: Path, tmp_path: Path, capsys):
    out = tmp_path / "out"
    argv = ["run", "--images", str(sample_dir), "--wheels", str(sample_dir / "log.csv"),
            "--out", str(out), "--record"]  # fmt: skip
    assert main(argv) == 0
    assert f"recording:  {out / 'run.rrd'}" in capsys.readouterr().out.splitlines()
    assert json.loads((out / "report.json").read_text())["outputs"]["recording"] == "run.rrd"
    rows, centres = _temporal_rows(out / "run.rrd")
    frames, trajectory = _csv_rows(out / "frames.csv"), _csv_rows(out / "trajectory.csv")
    assert rows["/camera/image"] == len(frames) == 96
    assert rows["/world/robot"] == rows["/states/x_icr/estimate"] == len(trajectory) == 2400
    assert rows["/camera/tiles"] == rows["/camera/roi"] == 96  # each frame: votes, or cleared
    boxed = [f for f in frames if f["roi_x0"]]
    assert len(centres) == len(boxed) > 80
    expected = [((float(f["roi_x0"]) + float(f["roi_x1"])) / 2,
                 (float(f["roi_y0"]) + float(f["roi_y1"])) / 2) for f in boxed]  # fmt: skip
    np.testing.assert_allclose([c for _, c in centres], expected)
    assert [t for t, _ in centres] == pytest.approx([float(f["t"]) for f in boxed])
    assert rows["/terrain"] == 3  # the start and the two changes


def test_the_real_grass_to_asphalt_log_is_recorded_row_by_row(drive_dir, warthog_yaml, tmp_path):
    log = drive_dir / "stitched_grass_to_asphalt.csv"
    out = tmp_path / "out"
    assert main(["run", "--wheels", str(log), "--config", str(warthog_yaml), "--out", str(out),
                 "--record"]) == 0  # fmt: skip
    rows, _ = _temporal_rows(out / "run.rrd")
    assert rows["/world/robot"] == rows["/states/y_l/upper"] == 5577
    assert rows["/terrain"] == 2 and "/camera/image" not in rows  # grass, then asphalt
    assert (out / "run.rrd").stat().st_size < 5e6


def test_without_rerun_record_is_one_line_before_anything_is_written(
    examples_dir: Path, tmp_path: Path, capsys, monkeypatch: pytest.MonkeyPatch
):
    monkeypatch.setitem(sys.modules, "rerun", None)  # as if rerun-sdk were not installed
    out = tmp_path / "out"
    argv = ["run", "--wheels", str(examples_dir / "demo_log.csv"), "--out", str(out), "--record"]
    assert main(argv) == 2
    assert capsys.readouterr().err == f"terrain-odom: error: {NEEDS_RERUN}\n"
    assert NEEDS_RERUN == "--record needs rerun-sdk: pip install 'terrain-odom[viz]'"
    assert not out.exists()


def test_overwrite_removes_the_previous_recording(examples_dir: Path, tmp_path: Path):
    out = tmp_path / "out"
    base = ["run", "--wheels", str(examples_dir / "demo_log.csv"), "--config",
            str(examples_dir / "demo.yaml"), "--out", str(out)]  # fmt: skip
    assert main([*base, "--record"]) == 0 and (out / "run.rrd").is_file()
    assert main([*base, "--overwrite"]) == 0
    assert not (out / "run.rrd").exists()  # no recording of another run left beside this one


def test_a_run_without_record_never_imports_rerun(examples_dir: Path, tmp_path: Path):
    code = (
        "import sys; from terrain_odom.cli.main import main; "
        f"assert main(['run', '--wheels', {str(examples_dir / 'demo_log.csv')!r}, "
        f"'--out', {str(tmp_path / 'out')!r}]) == 0; "
        "assert 'rerun' not in sys.modules, 'rerun imported'"
    )
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                          timeout=120, check=False)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
