"""``report.md``: a run's report rendered for people, and the Markdown table."""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, Any

from terrain_odom.estimation.time_offset import shows_pose_delay

if TYPE_CHECKING:
    from terrain_odom.estimation.pose_measurement import PoseUse
    from terrain_odom.estimation.time_offset import TimeCalibration
    from terrain_odom.evaluation.groundtruth import FrameTime
    from terrain_odom.evaluation.metrics import ErrorStats
    from terrain_odom.records import TerrainChange
    from terrain_odom.reporting.groundtruth import FrameScores, GroundTruthSection
    from terrain_odom.reporting.outage import OutageSection
    from terrain_odom.reporting.run_report import RunReport

__all__ = ["table", "run_markdown", "OUTAGE_HEADER", "outage_rows", "outage_markdown"]


def _cell(value: Any, digits: int) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.{digits}f}"
    return str(value)


def table(header: Sequence[str], rows: Iterable[Sequence[Any]], digits: int = 3) -> str:
    """Markdown table; floats with ``digits`` decimals, None as ``-``.

    Examples
    --------
    >>> print(table(["a", "b"], [["x", 0.5], ["y", None]]))
    | a | b |
    |---|---|
    | x | 0.500 |
    | y | - |
    """
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(_cell(v, digits) for v in row) + " |" for row in rows]
    return "\n".join(lines)


def _number(value: float | None) -> float | None:
    """None for NaN (shown ``-``, as in ``report.json``)."""
    return None if value is None or math.isnan(value) else value


def _percent(value: float | None) -> float | None:
    return None if value is None else 100.0 * value


def _changes(changes: Sequence[TerrainChange]) -> str:
    rows = [
        [c.t, c.t_confirmed, c.previous, c.label, c.reset, c.restored, c.prior] for c in changes
    ]
    if not rows:
        return "No terrain change was confirmed."
    return table(
        [
            "applied at (s)",
            "confirmed at (s)",
            "from",
            "to",
            "P reset",
            "memory restored",
            "offline prior",
        ],
        rows,
        digits=2,
    )


def _frames(frames: FrameScores) -> list[str]:
    accuracy = frames.accuracy
    acc_rows = [
        [label, a.frames, _percent(a.accuracy), a.confused_with or ""]
        for label, a in accuracy.per_terrain.items()
    ]
    overall = accuracy.overall
    acc_rows.append(["**all**", overall.frames, _percent(overall.accuracy), ""])
    return [
        "## Frame classification (true terrain of the ground each frame classified)",
        table(["true terrain", "frames", "accuracy %", "misclassified as"], acc_rows, digits=1),
        "## Feature extraction time per frame (Chen et al. 2023, Table 2 form)",
        _time_table(frames.feature_time),
        "## Feature extraction + KNN vote time per frame",
        _time_table(frames.classification_time),
    ]


def _time_table(times: dict[str, FrameTime]) -> str:
    rows = [
        [label, t.roi.mean_ms, t.roi.max_ms, t.full_frame.mean_ms, t.full_frame.max_ms, t.speedup]
        for label, t in times.items()
    ]
    header = ["true terrain", "with ROI: mean ms", "max ms", "whole frame: mean ms", "max ms"]
    return table([*header, "speed-up"], rows, digits=2)


def _odometry(section: GroundTruthSection) -> list[str]:
    rows = []
    for name, m in section.odometry.items():
        rows.append(
            [
                name,
                _number(m.mean_position_error_m),
                _number(m.mean_heading_error_deg),
                _number(m.summary.translation.median),
                _number(m.summary.rotation.median),
                ", ".join(f"{k} {v:.3f}" for k, v in m.per_terrain_mean_position_error_m.items()),
            ]
        )
    horizon = section.settings.horizon_m
    return [
        f"## Model-odometry error ({horizon:g} m windows from the true pose)",
        table(
            [
                "model",
                "mean position error (m)",
                "mean heading error (deg)",
                "median m/m",
                "median deg/m",
                "mean position error per terrain (m)",
            ],
            rows,
        ),
    ]


def _reconvergence(section: GroundTruthSection) -> list[str]:
    rows = []
    for name, changes in section.reconvergence.items():
        for c in changes:
            rows.append([name, c.t, f"{c.previous} -> {c.new}", c.settling_s])
    tol = section.settings.icr_tolerance_m
    return [
        f"## ICR re-convergence after each true terrain change (band +/- {tol:.3f} m)",
        table(["filter", "true change at (s)", "change", "re-converged after (s)"], rows, 2)
        + "\n\n`-`: not re-converged before the next change or the end of the run.",
    ]


def _pose_use(use: PoseUse) -> list[str]:
    """Return the pose components measured, used, dropped (by reason): ``counts.pose_components``."""
    dropped = {"position": 0, "heading": 0}
    reasons = []
    for key, n in use.dropped.items():
        component, reason = key.split(": ", 1)
        dropped[component] = dropped.get(component, 0) + n
        reasons.append([component, reason, n])
    rows = [
        ["position", use.position, use.used_position, dropped["position"]],
        ["heading", use.heading, use.used_heading, dropped["heading"]],
    ]
    parts = [
        "## Pose measurements (per component: position x, y; heading yaw)",
        table(["component", "measured", "used", "dropped"], rows),
    ]
    if reasons:
        parts.append(table(["dropped component", "why", "count"], reasons))
    return parts


OUTAGE_HEADER = (
    "outage",
    "windows",
    "model",
    "position m median [q25-q75]",
    "heading deg median [q25-q75]",
)
"""Columns of :func:`outage_rows`."""


def _quartiles(stats: ErrorStats, digits: int) -> str:
    if not stats.count or math.isnan(stats.median):
        return "n/a"
    return f"{stats.median:.{digits}f} [{stats.q25:.{digits}f}-{stats.q75:.{digits}f}]"


def outage_rows(section: OutageSection) -> list[list[str]]:
    """Rows of :data:`OUTAGE_HEADER` from an :class:`~terrain_odom.reporting.outage.OutageSection`: one per duration and model."""
    rows = []
    for duration, models in section.outages.items():
        windows = len(next(iter(models.values())).windows)
        for name, errors in models.items():
            rows.append(
                [
                    f"{duration:g} s",
                    str(windows),
                    name,
                    _quartiles(errors.position_stats, 2),
                    _quartiles(errors.heading_stats, 1),
                ]
            )
    return rows


def outage_markdown(section: OutageSection, title: str) -> list[str]:
    """Return a Markdown heading, how the windows are made, and the table of a section."""
    if section.skipped is not None:
        return [f"## {title}", f"Skipped: {section.skipped}."]
    return [
        f"## {title}",
        f"A window starts at a position fix every {section.every:g} s; each model is "
        "frozen at the run's state there and dead-reckoned with the logged wheel speeds, no "
        "pose update; its displacement (of the position sensor) is compared with the measured "
        "one.",
        table(list(OUTAGE_HEADER), outage_rows(section)),
    ]


def _warnings(warnings: Sequence[str]) -> list[str]:
    return ["## Warnings", "\n".join(f"- {w}" for w in warnings) if warnings else "None."]


def _pose_delay(timing: TimeCalibration) -> str:
    """Return the line on the pose delay applied: given, or estimated with its standard error."""
    std = timing.position_std
    if std is None and timing.estimate is not None:
        std = timing.estimate.std
    how = "given" if std is None else f"estimated, +-{std:.3f} s"
    return f"- pose delay: {timing.pose_delay:.3f} s ({how})"


def run_markdown(report: RunReport, plots: Sequence[str] = ()) -> str:
    """Render a run's report as Markdown.

    Parameters
    ----------
    report : RunReport
        The report (:func:`terrain_odom.app.run.run`).
    plots : sequence of str
        Relative paths of PNG plots to show.
    """
    counts = report.counts
    parts = [
        "# terrain-odom run report",
        f"- wheels: `{report.inputs.wheels}`",
        f"- terrain source: {report.terrain_source}; reset at: {report.config.terrain.reset_at}",
        f"- rows: {counts.rows}, pose measurements fused: {counts.updates}, "
        f"run time {report.run_time_s:.1f} s",
    ]
    parts += _pose_use(counts.pose_components)
    parts += _warnings(report.warnings)
    parts += outage_markdown(
        report.outage_guard, "Outage guard: the learned model against the nominal one"
    )
    parts += ["## Terrain changes", _changes(report.terrain_changes)]
    if report.inputs.priors is not None:
        parts.insert(2, f"- offline priors: `{report.inputs.priors}`")
    if shows_pose_delay(report.time_calibration.to_dict()):
        parts.insert(2, _pose_delay(report.time_calibration))
    section = report.groundtruth
    if section is not None:
        if section.frames is not None:
            parts += _frames(section.frames)
        parts += _odometry(section) + _reconvergence(section)
    if plots:
        parts.append("## Plots")
        parts += [f"![{p}]({p})" for p in plots]
    return "\n\n".join(parts) + "\n"
