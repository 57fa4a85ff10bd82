"""Training patches from a recording (``terrain-odom patches``).

From each camera frame, the ground region the robot is about to drive over
is cropped and filed under the terrain it was driven on, in the labelled
folder layout that ``terrain-odom train`` reads:
``OUT/<label>/<frame stem>.png``, plus ``OUT/patches.json`` (counts per
label; per recording the inputs, counts and frames skipped per reason; one
entry per patch). Several recordings can go into one folder (``append``,
e.g. one per terrain); a patch never replaces a file it did not write.

The region is that of ``terrain-odom run``: the robot's expanded footprint
``roi.horizon`` s ahead, predicted from the row's wheel speeds and the ICR
EKF's estimate when the frame arrives
(:func:`~terrain_odom.vision.camera.region_of_interest`). The EKF runs over
the log with the recording's labels, as ``run`` does with the log's terrain
column. Only regions entirely inside the image are cut: frames whose region
is clipped, outside the image or smaller than ``roi.min_size`` are skipped
and counted.

Which label: one for the whole recording (``label``), time intervals
(``intervals``: ``t_start,t_end,label``, :func:`read_intervals`) or the
log's ``terrain`` column. The region lies ahead of the robot, so a patch
takes the label at the time the robot *reaches* it: when, from the frame's
time, the robot has travelled the distance to the region's centre
(``ahead_m`` of ``frames.csv``), by the odometer of the EKF's motion
(:class:`~terrain_odom.estimation.terrain.Odometer`: the arrival rule by which
``run`` applies camera-confirmed changes). A frame
whose region the robot does not reach before its log segment ends is
skipped (``not_reached``), unless one label covers the whole recording.
"""

from __future__ import annotations

import json
import math
import re
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from terrain_odom.app.frames import read_frame
from terrain_odom.app.inputs import Chosen, ConfigEdits, choose_config, read_calibrated_log
from terrain_odom.config import Config, config_to_dict
from terrain_odom.errors import ConfigError, InputFileError
from terrain_odom.estimation.odometry import run_icr_ekf
from terrain_odom.estimation.terrain import Odometer
from terrain_odom.io._csv import read_csv, shown
from terrain_odom.io.atomic import write_atomic
from terrain_odom.io.folder import OutputFolder, writing
from terrain_odom.io.frames import FRAMES_CSV, FrameList, read_frames
from terrain_odom.io.paths import check_outputs
from terrain_odom.io.report import path_or_none, report_header, write_json
from terrain_odom.records import WheelLog
from terrain_odom.vision.camera import (
    GroundCamera,
    RoiResult,
    RoiStatus,
    crop,
    region_of_interest,
)

__all__ = [
    "PATCHES_JSON",
    "SKIP_REASONS",
    "LabelIntervals",
    "PatchesResult",
    "read_intervals",
    "make_patches",
]

PATCHES_JSON = "patches.json"
"""The report written beside the label folders."""

SKIP_REASONS = (
    "before_first_wheel_sample",
    "after_last_wheel_sample",
    "roi_clipped",
    "roi_outside",
    "roi_too_small",
    "not_reached",
    "unlabelled",
    "missing_or_unreadable",
)
"""Why a frame gives no patch (the keys of ``patches.json`` ``skipped``)."""

_LABEL = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.+-]*")


def _check_label(label: str, where: str, error: type[Exception] = ConfigError) -> str:
    """Return ``label`` if it can name a class folder; else raise ``error`` naming ``where``."""
    if not _LABEL.fullmatch(label):
        raise error(
            f"{where}: label {shown(label)} cannot name a class folder (letters, digits, "
            "'_', '.', '+', '-'; not starting with '.', '+' or '-')"
        )
    return label


@dataclass(frozen=True)
class LabelIntervals:
    """Terrain labels over time intervals ``[t_start, t_end)``, s, not overlapping.

    Examples
    --------
    >>> spans = LabelIntervals(np.array([0.0, 10.0]), np.array([10.0, 20.0]), ("grass", "gravel"))
    >>> [spans.at(t) for t in (0.0, 9.9, 10.0, 25.0)]
    ['grass', 'grass', 'gravel', '']
    """

    t_start: np.ndarray
    t_end: np.ndarray
    labels: tuple[str, ...]

    def at(self, t: float) -> str:
        """Return the label of the interval holding ``t`` (s), ``""`` if none does."""
        i = int(np.searchsorted(self.t_start, t, side="right")) - 1
        return self.labels[i] if i >= 0 and t < self.t_end[i] else ""


def _time(cell: str) -> float:
    value = float(cell)
    if not math.isfinite(value):
        raise ValueError(cell)
    return value


def read_intervals(path: str | Path) -> LabelIntervals:
    """Read a label interval file: a CSV with columns ``t_start,t_end,label`` (s, s, name).

    Raises
    ------
    InputFileError
        Missing column, a time that is not a finite number, ``t_end <=
        t_start``, overlapping intervals, or a label that cannot name a
        folder (the message names the file, line and column).
    """
    table = read_csv(path)
    table.require_columns("t_start", "t_end", "label", reason="labelled time intervals")
    if not len(table):
        raise table.error("no interval (one row per interval: t_start,t_end,label)")
    start, end = (
        table.convert(c, _time, np.float64, lambda x: f"{shown(x)} is not a finite time in s")
        for c in ("t_start", "t_end")
    )
    labels = [cell.strip() for cell in table.cells("label")]
    for row, label in enumerate(labels):
        if end[row] <= start[row]:
            raise table.error(f"t_end {end[row]:g} is not after t_start {start[row]:g}", row=row)
        _check_label(
            label, f"{table.name}, line {table.lines[row]}, column 'label'", InputFileError
        )
    order = np.argsort(start, kind="stable")
    for a, b in zip(order[:-1], order[1:], strict=True):
        if start[b] < end[a]:
            raise table.error(
                f"overlaps the interval on line {table.lines[a]} ({start[a]:g}-{end[a]:g} s)",
                row=int(b),
            )
    return LabelIntervals(start[order], end[order], tuple(labels[i] for i in order))


@dataclass(frozen=True)
class PatchesResult:
    """What :func:`make_patches` wrote and counted.

    Attributes
    ----------
    out_dir : Path
        The training folder.
    patches_json : Path
        Its ``patches.json``.
    counts : dict of str to int
        Patches written per label, sorted by label.
    skipped : dict of str to int
        Frames skipped per reason (:data:`SKIP_REASONS`; reasons with none left out).
    frames : int
        Frames listed.
    label_source : str
        ``label``, ``intervals`` or ``log`` (the log's terrain column).
    seconds : float
        Wall time, s.
    total : dict of str to int
        Patches per label in the folder (with ``append``, the earlier ones too).
    config : Chosen or None
        The configuration file read, and how it was chosen
        (:func:`~terrain_odom.app.inputs.choose_config`).
    """

    out_dir: Path
    patches_json: Path
    counts: dict[str, int]
    skipped: dict[str, int]
    frames: int
    label_source: str
    seconds: float
    total: dict[str, int] = field(default_factory=dict)
    config: Chosen | None = None


class _Labels:
    """The recording's labels: one, intervals, or the log's terrain column."""

    def __init__(self, log: WheelLog, label: str | None, intervals: LabelIntervals | None) -> None:
        self.log, self.label, self.intervals = log, label, intervals
        if label is not None:
            self.source = "label"
            _check_label(label, "--label")
        elif intervals is not None:
            self.source = "intervals"
        elif log.terrain is not None:
            self.source = "log"
            for name in sorted(set(map(str, log.terrain)) - {""}):
                _check_label(name, f"{log.source}, column 'terrain'", InputFileError)
        else:
            raise InputFileError(
                f"{log.source}: no 'terrain' column to label the patches with; give --label "
                "(a recording on one terrain) or --labels INTERVALS.csv"
            )

    @property
    def constant(self) -> bool:
        """Whether one label covers the whole recording."""
        return self.label is not None

    def at(self, t: float) -> str:
        """Return the label at time ``t``, s (``""``: none)."""
        if self.label is not None:
            return self.label
        if self.intervals is not None:
            return self.intervals.at(t)
        assert self.log.terrain is not None
        row = max(int(np.searchsorted(self.log.t, t, side="right")) - 1, 0)
        return str(self.log.terrain[row])

    def rows(self) -> list[str] | None:
        """Labels the EKF observes at the log's rows (gaps filled with the nearest label)."""
        if self.label is not None:
            return None
        labels = [self.at(float(t)) for t in self.log.t]
        known = [name for name in labels if name]
        if not known:
            return None
        current = known[0]
        for k, name in enumerate(labels):
            current = labels[k] = name or current
        return labels


@dataclass(frozen=True)
class _Patch:
    """A patch to cut: frame ``index``, its region's box, label, and times."""

    index: int
    roi: RoiResult
    label: str
    t: float
    t_label: float
    ahead: float


def _plan(
    frames: FrameList, log: WheelLog, config: Config, labels: _Labels, skipped: dict[str, int]
) -> list[_Patch]:
    """Place every frame's region and label it; count the frames skipped."""
    result = run_icr_ekf(log, config, labels=labels.rows())
    odometer = Odometer(log, result.states)
    camera = GroundCamera(config.camera)
    plan = []
    for index, t in enumerate(map(float, frames.t)):
        if t < log.t[0] or t > log.t[-1]:
            _skip(
                skipped, "before_first_wheel_sample" if t < log.t[0] else "after_last_wheel_sample"
            )
            continue
        row = int(np.searchsorted(log.t, t, side="right")) - 1
        roi = region_of_interest(
            camera, config.roi, log.v_l[row], log.v_r[row], result.states[row, 3:]
        )
        if roi.status is not RoiStatus.INSIDE or roi.box is None:
            _skip(skipped, f"roi_{roi.status.value}")
            continue
        reached = t if labels.constant else odometer.arrival(row, t, roi.ahead)
        if reached is None:
            _skip(skipped, "not_reached")
            continue
        label = labels.at(reached)
        if not label:
            _skip(skipped, "unlabelled")
            continue
        plan.append(_Patch(index, roi, label, t, reached, roi.ahead))
    return plan


def _skip(skipped: dict[str, int], reason: str) -> None:
    skipped[reason] = skipped.get(reason, 0) + 1


@dataclass(frozen=True)
class _Previous:
    """The patches already in the training folder (its ``patches.json``)."""

    patches: list[dict[str, Any]]
    recordings: list[dict[str, Any]]
    files: frozenset[str]  # relative to the folder


def _previous(out_dir: Path, overwrite: bool, append: bool) -> _Previous:
    """Read the patches already in ``out_dir``; refuse them unless ``overwrite`` or ``append``.

    Raises
    ------
    InputFileError
        ``out_dir/patches.json`` exists and neither option is given, or it is not
        one that ``patches`` wrote.
    ConfigError
        Both options.
    """
    if overwrite and append:
        raise ConfigError("--overwrite and --append exclude each other")
    report = out_dir / PATCHES_JSON
    if not report.is_file():
        return _Previous([], [], frozenset())
    if not (overwrite or append):
        raise InputFileError(_already(out_dir))
    try:
        data = json.loads(report.read_text(encoding="utf-8"))
        files = frozenset(str(entry["file"]) for entry in data["patches"])
        previous = _Previous(list(data["patches"]), list(data["recordings"]), files)
    except (ValueError, TypeError, KeyError):
        raise InputFileError(f"{report}: not a patches.json of 'terrain-odom patches'") from None
    return previous


def _already(out_dir: Path) -> str:
    return (
        f"{out_dir}: holds patches already ({PATCHES_JSON}); --append adds this recording's, "
        "--overwrite replaces them, or choose another --out"
    )


def _names(
    plan: list[_Patch], frames: FrameList, out_dir: Path, previous: _Previous, append: bool
) -> list[str]:
    """Name each patch ``label/<frame stem>.png`` (``-2``, ``-3`` ... where that is taken).

    Taken: the previous patches if they are kept (``append``), and any file
    in the folder that no ``patches`` wrote.
    """
    listed = previous.files
    taken = set(listed) if append else set()
    names = []
    for patch in plan:
        stem, n = frames.files[patch.index].stem, 1
        name = f"{patch.label}/{stem}.png"
        while name in taken or (name not in listed and (out_dir / name).exists()):
            n += 1
            name = f"{patch.label}/{stem}-{n}.png"
        taken.add(name)
        names.append(name)
    return names


def _check_size(plan: list[_Patch], frames: FrameList) -> None:
    """Refuse frames of another size than the camera's (the first readable one is checked).

    Raises
    ------
    InputFileError
        Naming the frame and both sizes.
    """
    for patch in plan:
        path = frames.files[patch.index]
        image, _ = read_frame(path)
        if image is None:
            continue
        try:
            crop(image, patch.roi)
        except ValueError as err:
            raise InputFileError(f"{path}: {err}; fix camera.width/height in --config") from None
        return


def _write_patch(path: Path, image: np.ndarray) -> None:
    """Write an RGB patch as PNG, atomically."""
    ok, data = cv2.imencode(".png", cv2.cvtColor(image, cv2.COLOR_RGB2BGR))
    if not ok:  # pragma: no cover - PNG encodes any uint8 image
        raise InputFileError(f"{path}: cannot encode the patch as PNG")
    write_atomic(path, lambda handle: handle.write(data.tobytes()))


def _cut(
    plan: list[_Patch],
    names: list[str],
    frames: FrameList,
    out: Path,
    skipped: dict[str, int],
) -> list[dict[str, Any]]:
    """Decode the frames of ``plan`` and write their patches; return the entries written."""
    written = []
    for patch, name in zip(plan, names, strict=True):
        path = frames.files[patch.index]
        image, _ = read_frame(path)
        width, height = patch.roi.image_size
        if image is None or image.shape[:2] != (height, width):
            _skip(skipped, "missing_or_unreadable")
            continue
        (out / patch.label).mkdir(exist_ok=True)
        _write_patch(out / name, crop(image, patch.roi))
        written.append(
            {
                "file": name,
                "label": patch.label,
                "t": patch.t,
                "t_label": patch.t_label,
                "ahead_m": patch.ahead,
                "box": list(patch.roi.box or ()),
                "frame": str(path),
            }
        )
    return written


def _counts(entries: list[dict[str, Any]]) -> dict[str, int]:
    """Patches per label, sorted by label."""
    return dict(sorted(Counter(str(entry["label"]) for entry in entries).items()))


def make_patches(
    images: str | Path,
    wheels: str | Path,
    out_dir: str | Path,
    *,
    label: str | None = None,
    intervals: str | Path | None = None,
    config: Config | None = None,
    config_path: str | Path | None = None,
    edits: ConfigEdits | None = None,
    overwrite: bool = False,
    append: bool = False,
) -> PatchesResult:
    """Cut labelled training patches from a recording's frames (see the module doc).

    Parameters
    ----------
    images : str or Path
        Folder of camera frames (:mod:`terrain_odom.io.frames`).
    wheels : str or Path
        The wheel log; read and delayed as ``run`` reads it
        (:func:`~terrain_odom.app.inputs.read_calibrated_log`).
    out_dir : str or Path
        Training folder (created): ``<label>/<frame stem>.png`` and
        ``patches.json``, locked and recorded in its manifest
        (:mod:`terrain_odom.io.folder`). Refused if it holds patches
        already, unless ``overwrite`` or ``append``.
    label : str, optional
        One label for the whole recording.
    intervals : str or Path, optional
        Label interval file (:func:`read_intervals`). Without ``label`` or
        ``intervals``, the log's ``terrain`` column labels the patches.
    config, config_path : optional
        Configuration (camera, region of interest, robot, filter); loaded from
        ``config_path``, else ``images/config.yaml`` if it exists, else the
        built-in defaults (:func:`~terrain_odom.app.inputs.choose_config`).
    edits : ConfigEdits, optional
        The command line's changes to a configuration file's values
        (``--horizon``: ``roi_horizon``).
    overwrite : bool
        Replace the patches already in ``out`` (those its manifest records as
        written by ``patches``; every other file is kept).
    append : bool
        Add this recording's patches to those already in ``out`` (a name
        taken gets ``-2``, ``-3`` ...), e.g. one recording per terrain.

    Returns
    -------
    PatchesResult

    Raises
    ------
    InputFileError
        Unreadable inputs; an output would overwrite an input; a frame of
        another size than the configured camera's; a file among those it
        would write that ``patches`` did not write (``patches.json`` of a
        folder written before the manifest, or by hand).
    ConfigError
        Both ``label`` and ``intervals``, or ``overwrite`` and ``append``; a
        label that cannot name a folder.
    """
    started = time.perf_counter()
    if label is not None and intervals is not None:
        raise ConfigError("--label and --labels exclude each other")
    chosen = choose_config(config, config_path, edits=edits, images=images)
    with writing(out_dir, "patches") as folder:  # locked; never a file patches did not write
        return _make_patches(
            images, wheels, folder, label, intervals, chosen.config, chosen.file, overwrite,
            append, started,
        )  # fmt: skip


def _make_patches(
    images: str | Path,
    wheels: str | Path,
    folder: OutputFolder,
    label: str | None,
    intervals: str | Path | None,
    config: Config,
    config_file: Chosen,
    overwrite: bool,
    append: bool,
    started: float,
) -> PatchesResult:
    """:func:`make_patches` into the locked ``folder`` with ``config`` (read from ``config_file``)."""
    root = folder.path
    previous = _previous(root, overwrite, append)
    config_path = config_file.path
    spans = None if intervals is None else read_intervals(intervals)
    log, _ = read_calibrated_log(wheels, config)
    labels = _Labels(log, label, spans)
    frames = read_frames(images)
    skipped: dict[str, int] = {}
    plan = _plan(frames, log, config, labels, skipped)
    kept = previous if append else _Previous([], [], frozenset())
    names = _names(plan, frames, root, previous, append)
    inputs = [wheels, config_path, intervals, Path(images) / FRAMES_CSV, *frames.files]
    check_outputs(inputs, [root / PATCHES_JSON, *(root / name for name in names)])
    _check_size(plan, frames)
    # appending keeps its previous patches and rewrites patches.json; else all are replaced
    folder.prepare(
        [PATCHES_JSON, *names],
        overwrite=overwrite or append,
        all_previous=not append,
        refuse=lambda _: _already(root),
    )
    written = _cut(plan, names, frames, root, skipped)
    skipped = {reason: skipped[reason] for reason in SKIP_REASONS if reason in skipped}
    recording = {
        "inputs": {
            "images": path_or_none(images),
            "wheels": path_or_none(wheels),
            "config": path_or_none(config_path),
            "labels": path_or_none(intervals),
            "label": label,
        },
        "label_source": labels.source,
        "label_time": "arrival at the region (odometer of the ICR EKF's motion)",
        "config": config_to_dict(config),
        "frames": len(frames),
        "counts": _counts(written),
        "skipped": skipped,
    }
    total = _write_report(root, kept, recording, written)
    seconds = time.perf_counter() - started
    return PatchesResult(
        root,
        root / PATCHES_JSON,
        _counts(written),
        skipped,
        len(frames),
        labels.source,
        seconds,
        total=total,
        config=config_file,
    )


def _write_report(
    out_dir: Path, kept: _Previous, recording: dict[str, Any], written: list[dict[str, Any]]
) -> dict[str, int]:
    """Write ``patches.json``: the kept patches and this recording's; return the counts."""
    number = len(kept.recordings)
    patches = kept.patches + [{**entry, "recording": number} for entry in written]
    total = _counts(patches)
    report = {
        **report_header("patches"),
        "counts": total,
        "recordings": [*kept.recordings, recording],
        "patches": patches,
    }
    write_json(out_dir / PATCHES_JSON, report)
    return total
