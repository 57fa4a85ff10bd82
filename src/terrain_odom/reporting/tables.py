"""The Markdown tables of ``compare`` (``compare.md``) and of ``evaluate`` over many logs.

Plain text from figures the app computed: error statistics
(:class:`~terrain_odom.evaluation.ErrorSummary`), parameter values and the
rows of a batch; :func:`~terrain_odom.reporting.markdown.table` draws them.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from typing import Any

from terrain_odom.evaluation import ErrorSummary
from terrain_odom.reporting.markdown import table

__all__ = [
    "BOUND_MARK",
    "format_error_stats",
    "format_params",
    "compare_markdown",
    "evaluation_markdown",
]

BOUND_MARK = "!"
"""Marks a parameter at or within 1 % of a search bound in the compare tables."""


def format_error_stats(s: ErrorSummary) -> tuple[str, str]:
    """Return the per-metre errors as ``median [q25-q75]`` texts: m/m, deg/m (n/a: no window)."""
    t, r = s.translation, s.rotation
    if t.count == 0:
        return "n/a", "n/a"
    return (
        f"{t.median:.4f} [{t.q25:.3f}-{t.q75:.3f}]",
        f"{r.median:.3f} [{r.q25:.2f}-{r.q75:.2f}]",
    )


def format_params(values: Mapping[str, float], at_bounds: Collection[str]) -> str:
    """Return a parameter set as ``name=value`` (``c``, ``e`` for the derived quantities).

    A value at a search bound is marked :data:`BOUND_MARK`; no value: ``-``.

    Examples
    --------
    >>> format_params({"y_l": 0.31, "steering_efficiency": 0.8}, ["y_l"])
    'y_l=0.310!, c=0.800'
    """
    short = {"steering_efficiency": "c", "eccentricity": "e"}
    return (
        ", ".join(
            f"{short.get(k, k)}={v:.3f}{BOUND_MARK if k in at_bounds else ''}"
            for k, v in values.items()
        )
        or "-"
    )


def compare_markdown(
    groups: Sequence[str],
    params: Sequence[Sequence[str]],
    errors: Sequence[tuple[str, str, ErrorSummary, float]],
    track_width: float,
    h_t: str,
    h_e: float,
) -> str:
    """Return ``compare.md``: the parameters per model and group, then the held-out errors.

    Parameters
    ----------
    groups : sequence of str
        The column of each group (a terrain, or all the training logs).
    params : sequence of sequences of str
        Per model: its name, then its cell per group (:func:`format_params`).
    errors : sequence of (model, group, ErrorSummary, fit seconds)
        The held-out errors, one row each.
    track_width : float
        Nominal ``B``, m.
    h_t : str
        Training horizon, as given (``2m``, ``2s``).
    h_e : float
        Evaluation horizon, m.
    """
    error_rows = [
        [name, group, summary.translation.count, *format_error_stats(summary), f"{fit_s:.1f}"]
        for name, group, summary, fit_s in errors
    ]
    lines = [
        f"Parameters per model and terrain (trained on h_t = {h_t} segments; "
        f"c = (y_l - y_r) / B with B = {track_width:g} m, e = eccentricity; "
        f"{BOUND_MARK}: at or within 1 % of a search bound)",
        "",
        table(["model", *groups], params),
        "",
        f"Held-out error per metre over h_e = {h_e:g} m windows: median [q25-q75]",
        "",
        table(["model", "terrain", "windows", "m/m", "deg/m", "fit (s)"], error_rows),
    ]
    return "\n".join(lines) + "\n"


def evaluation_markdown(
    horizon: float,
    rows: Sequence[tuple[str, str, int, ErrorSummary, float]],
    notes: Sequence[str] = (),
) -> str:
    """Return ``evaluation.md`` of a batch: one row per log (or pool) and model.

    Parameters
    ----------
    horizon : float
        Evaluation horizon ``h_e``, m.
    rows : sequence of (log, model, windows, ErrorSummary, ATE RMSE in m)
        The table's rows.
    notes : sequence of str
        One line each below the table (what a log's windows run between).
    """
    cells: list[list[Any]] = [
        [log, model, windows, *format_error_stats(errors), ate]
        for log, model, windows, errors, ate in rows
    ]
    head = ["log", "model", "windows", "m/m median [q25-q75]", "deg/m median [q25-q75]"]
    text = "".join(f"- {note}\n" for note in notes)
    return (
        f"Model-odometry error per metre over h_e = {horizon:g} m windows, "
        "and dead-reckoning ATE\n\n"
        + table([*head, "ATE DR (m)"], cells)
        + "\n"
        + (f"\n{text}" if text else "")
    )
