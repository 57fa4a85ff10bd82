"""A run's output folder: one run per folder, its state recorded in ``report.json``.

:func:`~terrain_odom.app.run.run` writes its files under fixed names
(:data:`RUN_FILES`) into a folder locked while it runs (:func:`run_folder`).
A folder that already holds a run is refused unless the caller asks to
overwrite it, and then the previous run's files (and only those, as the
folder's manifest records them: :mod:`terrain_odom.io.folder`) are removed
first, so old and new files never mix; a file among :data:`RUN_FILES` that a
run did not write (an import's ``config.yaml``, a hand-edited file) is never
replaced. While the run
streams, ``report.json`` says ``"status": "running"``; an interrupted run
rewrites it with ``"status": "interrupted"`` and the rows written so far; a
finished run's full report says ``"status": "complete"``; a report still
saying ``running`` in a folder nobody holds is a run whose process is gone.
Whatever reads a run (``evaluate --run``) calls :func:`check_complete`.
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
import json
import os
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, ParamSpec, TypeVar

from terrain_odom.app.locate import output_folder
from terrain_odom.app.plots import EVALUATION_PLOTS, PLOT_FILES, PLOTS_DIR
from terrain_odom.errors import InputFileError, TerrainOdomError
from terrain_odom.io.folder import OutputFolder, holder, writing
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
    "run_folder",
    "holds_run_folder",
    "prepare_folder",
    "check_folder",
    "mark_running",
    "mark_interrupted",
    "interruption_reason",
    "check_complete",
]

_P = ParamSpec("_P")
_R = TypeVar("_R")

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


@contextlib.contextmanager
def run_folder(out_dir: str | Path, *, overwrite: bool = False) -> Iterator[Path]:
    """Create and lock the output folder of a run; empty it of a previous run's files.

    The folder is locked for the life of the ``with`` block and its manifest
    records the run's files (:func:`~terrain_odom.io.folder.writing`).

    Parameters
    ----------
    out_dir : str or Path
        The folder (created with its parents).
    overwrite : bool
        Remove the files of the run already in the folder (and of ``evaluate``
        into it), nothing else; without it such a folder is refused.

    Yields
    ------
    Path
        The folder.

    Raises
    ------
    InputFileError
        ``out_dir`` is a file, is in use by another command, holds a run and
        ``overwrite`` is false, or holds a file among :data:`RUN_FILES` that a
        run did not write (another command's, edited since, unknown).
    """
    with writing(out_dir, "run") as folder:
        _prepare(folder, overwrite=overwrite)
        try:
            yield folder.path
        except BaseException as exc:
            _mark_stopped(folder.path, exc)
            raise


def _mark_stopped(out_dir: Path, exc: BaseException) -> None:
    """Mark a run that stopped after its stream (drawing, reporting) interrupted.

    A run stopped while streaming has said so already (with the rows
    written); any later stop leaves ``report.json`` saying ``running``.
    """
    try:
        report = _report(out_dir / REPORT_JSON)
    except (OSError, ValueError, AttributeError):
        return
    if report.get("status") != RUNNING:
        return
    try:
        with open(out_dir / TRAJECTORY_CSV, "rb") as handle:
            rows = sum(block.count(b"\n") for block in iter(lambda: handle.read(1 << 20), b"")) - 1
    except OSError:
        rows = 0
    mark_interrupted(out_dir, report.get("inputs", {}), max(rows, 0), exc)


_HELD: contextvars.ContextVar[contextlib.ExitStack | None] = contextvars.ContextVar(
    "run_folders", default=None
)


def holds_run_folder(function: Callable[_P, _R]) -> Callable[_P, _R]:
    """Decorate a function calling :func:`prepare_folder`: the folder stays locked till it returns."""

    @functools.wraps(function)
    def wrapper(*args: _P.args, **kwargs: _P.kwargs) -> _R:
        with contextlib.ExitStack() as stack:
            token = _HELD.set(stack)
            try:
                return function(*args, **kwargs)
            finally:
                _HELD.reset(token)

    return wrapper


def prepare_folder(out_dir: str | Path, *, overwrite: bool = False) -> Path:
    """Open the output folder of a run (:func:`run_folder`) until the decorated caller returns.

    Only within a function decorated with :func:`holds_run_folder` (else
    ``RuntimeError``), which releases the folder when it returns or raises.
    """
    stack = _HELD.get()
    if stack is None:
        raise RuntimeError("prepare_folder needs a caller decorated with holds_run_folder")
    return stack.enter_context(run_folder(out_dir, overwrite=overwrite))


def check_folder(out_dir: str | Path, *, overwrite: bool = False) -> None:
    """Refuse an output folder :func:`run_folder` would refuse, changing nothing in it."""
    if Path(out_dir).is_dir():
        with writing(out_dir, "run") as folder:
            _prepare(folder, overwrite=overwrite, remove=False)
    else:
        output_folder(out_dir)


def _prepare(folder: OutputFolder, *, overwrite: bool, remove: bool = True) -> None:
    def refuse(previous: list[str]) -> str:
        found = [name for name in _MARKS if name in previous] or previous[:3]
        return (
            f"{folder.path}: already holds {_which_run(folder.path)} ({', '.join(found)}); "
            "choose another --out, or --overwrite to replace it"
        )

    folder.prepare(
        RUN_FILES, overwrite=overwrite, replaces=("evaluate",), refuse=refuse, remove=remove
    )


def _which_run(out_dir: Path) -> str:
    """Return "a run", or "an interrupted run" etc. as ``out_dir/report.json`` says.

    Called with the folder locked: a run still marked running is gone.
    """
    try:
        report = _report(out_dir / REPORT_JSON)
    except (OSError, ValueError, AttributeError):
        return "a run"
    status = report.get("status", COMPLETE)
    if status == RUNNING:
        return f"an interrupted run ({_process(report)} is gone)"
    return "an interrupted run" if status == INTERRUPTED else "a run"


def _process(report: dict[str, Any]) -> str:
    pid = report.get("pid")
    return f"process {pid}" if isinstance(pid, int) else "its process"


def _report(path: Path) -> dict[str, Any]:
    """Return the run report ``path``.

    Raises ``OSError``, or ``ValueError`` / ``AttributeError`` if it is not a
    JSON object.
    """
    report = json.loads(path.read_text(encoding="utf-8"))
    report.get("status")  # AttributeError unless a JSON object
    return report


def mark_running(out_dir: Path, inputs: dict[str, Any]) -> None:
    """Write ``report.json`` saying the run in ``out_dir`` has started (with its ``inputs``)."""
    write_json(
        out_dir / REPORT_JSON,
        {**report_header("run"), "status": RUNNING, "pid": os.getpid(), "inputs": inputs},
    )


def mark_interrupted(out_dir: Path, inputs: dict[str, Any], rows: int, exc: BaseException) -> None:
    """Rewrite ``report.json``: the run stopped after ``rows`` rows because of ``exc``.

    The reason is the exception's one line (``interrupted by the user`` for
    Ctrl-C, ``interrupted by SIGTERM`` ...). A report that cannot be written
    (a full disk) is left saying ``running``: the folder's lock, released
    with the process, then tells that run's process is gone.
    """
    report = {
        **report_header("run"),
        "status": INTERRUPTED,
        "pid": os.getpid(),
        "reason": interruption_reason(exc),
        "inputs": inputs,
        "rows_written": rows,
    }
    with contextlib.suppress(OSError):  # the error at hand (e.g. a full disk) says more
        write_json(out_dir / REPORT_JSON, report)


def interruption_reason(exc: BaseException) -> str:
    """Return why a run stopped, in one line, from the exception that stopped it."""
    if isinstance(exc, KeyboardInterrupt):
        return str(exc) or "interrupted by the user"
    if isinstance(exc, TerrainOdomError):
        return str(exc)
    return repr(exc)


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
        report = _report(path)
    except (ValueError, AttributeError) as exc:
        raise InputFileError(f"{path}: not a run report ({exc})") from None
    status = report.get("status", COMPLETE)
    if status == COMPLETE:
        return
    if status == RUNNING:
        held = holder(run_dir)
        if held is not None:
            raise InputFileError(
                f"{path}: the run is still running ({held.describe()}); wait for it to finish"
            )
        status = f"interrupted, {_process(report)} is gone"
    raise InputFileError(
        f"{path}: the run did not complete (status: {status}); run it again with --overwrite"
    )
