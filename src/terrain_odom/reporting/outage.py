"""Outage-window errors as reports show them: a JSON section and a figure.

Their table is :func:`terrain_odom.reporting.markdown.outage_rows`.

Shared by ``evaluate`` (the run's model beside the ideal differential
drive and parameter files) and ``run``'s guard (the learned model beside the
nominal one it started from); see :mod:`terrain_odom.evaluation.outage`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from terrain_odom.evaluation.outage import OutageErrors
from terrain_odom.reporting.figure import new_figure, wrap

__all__ = [
    "Outages",
    "OutageSection",
    "outage_section",
    "outage_figure",
]

Outages = Mapping[float, Mapping[str, OutageErrors]]
"""Per outage duration (s), per model name: its errors."""


def outage_section(outages: Outages, every: float, **extra: Any) -> dict[str, Any]:
    """Return the ``outages`` entry of a report: per duration, windows and per-model statistics.

    ``every``: the time between window starts, s
    (:func:`~terrain_odom.evaluation.outage.outage_spacing`); ``extra`` items
    (e.g. the guard's verdict) are added to the entry.
    """
    durations: dict[str, Any] = {}
    for duration, models in outages.items():
        first = next(iter(models.values()))
        durations[f"{duration:g}"] = {
            "windows": len(first.windows),
            "models": {name: e.to_dict() for name, e in models.items()},
        }
    return {"every_s": every, "durations": durations, **extra}


@dataclass(frozen=True)
class OutageSection:
    """Outage-window errors as a report's section; :meth:`to_dict` is its JSON.

    Attributes
    ----------
    outages : Outages
        Per duration, per model: the errors.
    every : float
        Time between window starts, s.
    learned_worse_s : tuple of float or None
        The guard's verdict: durations where the learned model is worse (None: no verdict).
    skipped : str or None
        Why there was nothing to compare (then the section is only that).
    """

    outages: Outages = field(default_factory=dict)
    every: float = 0.0
    learned_worse_s: tuple[float, ...] | None = None
    skipped: str | None = None

    def to_dict(self) -> dict[str, Any]:
        """Return the section: :func:`outage_section`'s, or ``{"skipped": why}``."""
        if self.skipped is not None:
            return {"skipped": self.skipped}
        if self.learned_worse_s is None:
            return outage_section(self.outages, self.every)
        return outage_section(self.outages, self.every, learned_worse_s=list(self.learned_worse_s))


def outage_figure(outages: Outages) -> Any:
    """Box plots of the outage errors: one column per duration, position (m) and heading (deg).

    Returns
    -------
    matplotlib.figure.Figure
        The heading row only where some heading was measured; each box
        annotated with its median.
    """
    durations = list(outages)
    headings = any(np.isfinite(e.heading).any() for m in outages.values() for e in m.values())
    n_rows = 2 if headings else 1
    names = list(next(iter(outages.values()))) if outages else []
    fig = new_figure(max(5.0, 1.3 + 1.6 * len(names) * len(durations)), 3.2 * n_rows + 0.6)
    axes = np.atleast_2d(fig.subplots(n_rows, max(1, len(durations)), squeeze=False))
    measures = [("position error (m)", lambda e: e.position)]
    if headings:
        measures.append(("heading error (deg)", lambda e: np.degrees(e.heading)))
    for col, duration in enumerate(durations):
        models = outages[duration]
        for row, (label, values_of) in enumerate(measures):
            ax = axes[row, col]
            data = [values_of(e)[np.isfinite(values_of(e))] for e in models.values()]
            keep = [i for i, d in enumerate(data) if d.size]
            if keep:
                ax.boxplot([data[i] for i in keep], positions=keep, widths=0.5, showfliers=False,
                           medianprops={"color": "black"})  # fmt: skip
                for i in keep:  # every window as a point, the median named beside its box
                    jitter = np.linspace(-0.12, 0.12, data[i].size)
                    ax.plot(i + jitter, data[i], ".", color="tab:blue", alpha=0.6, ms=5)
                    median = float(np.median(data[i]))
                    ax.text(i + 0.28, median, f"{median:.2f}", fontsize=8, va="center")
            ax.set_xticks(range(len(models)), [wrap(n, 18) for n in models], fontsize=8)
            ax.set_xlim(-0.5, len(models) - 0.2)
            ax.grid(True, axis="y", alpha=0.3)
            if col == 0:
                ax.set_ylabel(label)
            if row == 0:
                n = len(next(iter(models.values())).windows)
                ax.set_title(f"{duration:g} s outages ({n} windows)")
    fig.suptitle("Dead reckoning from the run's state, no pose updates")
    return fig
