"""A run's output folder: one run per folder, its state recorded in ``report.json``.

:func:`~terrain_odom.app.run.run` writes its files under fixed names
(:data:`RUN_FILES`). A folder that already holds a run is refused unless the
caller asks to overwrite it, and then the previous run's files (and only
those) are removed first, so old and new files never mix. While the run
streams, ``report.json`` says ``"status": "running"``; an interrupted run
rewrites it with ``"status": "interrupted"`` and the rows written so far; a
finished run's full report says ``"status": "complete"``. Whatever reads a run
(``evaluate --run``) calls :func:`check_complete`.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from terrain_odom.app.locate import output_folder
from terrain_odom.app.plots import EVALUATION_PLOTS, PLOT_FILES, PLOTS_DIR
from terrain_odom.errors import InputFileError
from terrain_odom.io.frames import FRAMES_CSV
from terrain_odom.io.report import report_header, write_json

__all__ = [
    "TRAJECTORY_CSV",
    "TRAJECTORY_TUM",
    "FRAMES_CSV",
    "REPORT_JSON",
    "REPORT_MD",
    "RUN_CONFIG",
    "RECORDING",
    "EVALUATION_JSON",
    "PLOTS",
    "RUN_FILES",
    "COMPLETE",
    "prepare_folder",
    "mark_running",
    "mark_interrupted",
    "check_complete",
]

TRAJECTORY_CSV = "trajectory.csv"
TRAJECTORY_TUM = "trajectory.tum"
REPORT_JSON = "report.json"
REPORT_MD = "report.md"
RUN_CONFIG = "config.yaml"
"""The configuration a run used, written into its folder."""
RECORDING = "run.rrd"
"""The Rerun recording of ``run --record``."""
EVALUATION_JSON = "evaluation.json"
"""Written into a run's folder by ``evaluate --run`` (the default ``--out``)."""
PLOTS = (*PLOT_FILES, *EVALUATION_PLOTS)
"""Plots a run (and ``evaluate`` into its folder) may draw into ``plots/``."""
RUN_FILES = (
    TRAJECTORY_CSV,
    TRAJECTORY_TUM,
    FRAMES_CSV,
    REPORT_JSON,
    REPORT_MD,
    RUN_CONFIG,
    RECORDING,
    EVALUATION_JSON,
    *(f"{PLOTS_DIR}/{name}" for name in PLOTS),
)
"""Every file a run (and ``evaluate`` into its folder) may write, relative to the folder."""
_MARKS = (REPORT_JSON, TRAJECTORY_CSV, TRAJECTORY_TUM)
"""Files that only a run writes: one of them in a folder means it holds a run."""
COMPLETE = "complete"
RUNNING = "running"
INTERRUPTED = "interrupted"


def prepare_folder(out_dir: str | Path, *, overwrite: bool = False) -> Path:
    """Create the output folder of a run, or empty it of a previous run's files.

    Parameters
    ----------
    out_dir : str or Path
        The folder (created with its parents).
    overwrite : bool
        Remove the files of a run already in the folder (:data:`RUN_FILES`,
        nothing else); without it such a folder is refused.

    Returns
    -------
    Path
        The folder.

    Raises
    ------
    InputFileError
        ``out_dir`` is a file, or holds a run and ``overwrite`` is false.
    """
    out = output_folder(out_dir)
    found = [name for name in _MARKS if (out / name).exists()]
    if found and not overwrite:
        raise InputFileError(
            f"{out}: already holds {_which_run(out)} ({', '.join(found)}); choose another "
            "--out, or --overwrite to replace it"
        )
    for name in RUN_FILES if found else ():
        (out / name).unlink(missing_ok=True)
    if found and (out / PLOTS_DIR).is_dir() and not any((out / PLOTS_DIR).iterdir()):
        (out / PLOTS_DIR).rmdir()  # emptied of the previous run's plots
    out.mkdir(parents=True, exist_ok=True)
    return out


def _which_run(out: Path) -> str:
    """Return "a run", or "an interrupted run" etc. as ``out/report.json`` says."""
    try:
        status = _status(out / REPORT_JSON)
    except (OSError, ValueError, AttributeError):
        status = None
    return f"an {status} run" if status in (RUNNING, INTERRUPTED) else "a run"


def _status(path: Path) -> object:
    """Return the ``status`` of the run report ``path`` (:data:`COMPLETE` if it has none).

    Raises ``OSError``, or ``ValueError`` / ``AttributeError`` if it is not a
    JSON object.
    """
    return json.loads(path.read_text(encoding="utf-8")).get("status", COMPLETE)


def mark_running(out: Path, inputs: dict[str, Any]) -> None:
    """Write ``report.json`` saying the run in ``out`` has started (with its ``inputs``)."""
    write_json(out / REPORT_JSON, {**report_header("run"), "status": RUNNING, "inputs": inputs})


def mark_interrupted(out: Path, inputs: dict[str, Any], rows: int, reason: str) -> None:
    """Rewrite ``report.json``: the run stopped after ``rows`` rows because of ``reason``."""
    write_json(
        out / REPORT_JSON,
        {
            **report_header("run"),
            "status": INTERRUPTED,
            "reason": reason,
            "inputs": inputs,
            "rows_written": rows,
        },
    )


def check_complete(run_dir: str | Path) -> None:
    """Refuse a run folder whose ``report.json`` does not say the run completed.

    A folder without ``report.json`` passes (a trajectory made elsewhere);
    a report without ``status`` (written before the status existed) passes.

    Raises
    ------
    InputFileError
        The run is running, was interrupted, or its report is not JSON.
    """
    path = Path(run_dir) / REPORT_JSON
    if not path.is_file():
        return
    try:
        status = _status(path)
    except (ValueError, AttributeError) as exc:
        raise InputFileError(f"{path}: not a run report ({exc})") from None
    if status != COMPLETE:
        raise InputFileError(
            f"{path}: the run did not complete (status: {status}); run it again with --overwrite"
        )
