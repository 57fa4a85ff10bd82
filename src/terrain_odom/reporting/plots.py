"""PNG plots of a run against ground truth (matplotlib, Agg canvas: no display needed).

Each function draws into a binary handle, so files are written atomically by
the caller (:func:`terrain_odom.io.atomic.write_atomic`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, BinaryIO

import numpy as np

from terrain_odom.estimation.odometry import OdometryResult
from terrain_odom.records import GroundTruth

__all__ = ["new_figure", "plot_trajectory", "plot_icr", "plot_frames"]

_DPI = 110


def new_figure(width: float, height: float) -> Any:
    """Return a matplotlib ``Figure`` on the Agg canvas (no display, no pyplot state).

    matplotlib is imported here, so importing this module stays cheap.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _figure(width: float, height: float, rows: int = 1) -> tuple[Any, Any]:
    fig = new_figure(width, height)
    return fig, fig.subplots(rows, 1, sharex=True, squeeze=False)[:, 0]


def plot_trajectory(
    handle: BinaryIO, gt: GroundTruth, t: np.ndarray, results: Mapping[str, OdometryResult]
) -> None:
    """Estimated trajectories of the filter variants against the true one (x, y in m)."""
    fig, (ax,) = _figure(7.0, 4.2)
    inside = (gt.t >= t[0]) & (gt.t <= t[-1])
    ax.plot(gt.pose[inside, 0], gt.pose[inside, 1], "k-", lw=2.5, alpha=0.4, label="ground truth")
    for name, result in results.items():
        ax.plot(result.states[:, 0], result.states[:, 1], lw=1.0, label=name)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(fontsize=8)
    ax.set_title("trajectory")
    fig.savefig(handle, format="png", dpi=_DPI)


def plot_icr(
    handle: BinaryIO,
    gt: GroundTruth,
    t: np.ndarray,
    results: Mapping[str, OdometryResult],
    changes: Sequence[dict[str, Any]],
) -> None:
    """ICR estimates over time against the truth; true terrain changes as dashed lines."""
    names = ("y_l", "y_r", "x_icr")
    fig, axes = _figure(8.0, 7.0, rows=len(names))
    inside = (gt.t >= t[0]) & (gt.t <= t[-1])
    for i, (ax, name) in enumerate(zip(axes, names, strict=True)):
        ax.plot(gt.t[inside], gt.icr[inside, i], "k-", lw=2.5, alpha=0.4, label="truth")
        for label, result in results.items():
            ax.plot(t, result.states[:, list(result.names).index(name)], lw=1.0, label=label)
        for change in changes:
            ax.axvline(change["t"], color="grey", ls="--", lw=0.8)
        ax.set_ylabel(f"{name} (m)")
    axes[0].legend(fontsize=8, ncol=2)
    axes[0].set_title("ICR estimates (dashed: true terrain changes)")
    axes[-1].set_xlabel("t (s)")
    fig.savefig(handle, format="png", dpi=_DPI)


def plot_frames(
    handle: BinaryIO, t: np.ndarray, labels: Sequence[str], truth: Sequence[str]
) -> None:
    """Frame labels against the true terrain of the classified ground, over time."""
    classes = sorted({str(c) for c in (*labels, *truth) if c})
    row = {c: i for i, c in enumerate(classes)}
    fig, (ax,) = _figure(8.0, 2.2 + 0.3 * len(classes))
    truth_y = np.array([row.get(str(c), np.nan) for c in truth], dtype=float)
    label_y = np.array([row.get(str(c), np.nan) for c in labels], dtype=float)
    wrong = label_y != truth_y
    ax.plot(t, truth_y, "k-", lw=6, alpha=0.25, label="true terrain")
    ax.plot(t[~wrong], label_y[~wrong], "g.", ms=4, label="label (right)")
    ax.plot(t[wrong], label_y[wrong], "rx", ms=5, label="label (wrong)")
    ax.set_yticks(range(len(classes)), classes)
    ax.set_ylim(-0.5, len(classes) - 0.5)
    ax.set_xlabel("t (s)")
    ax.legend(fontsize=8, loc="upper right")
    ax.set_title("frame labels")
    fig.savefig(handle, format="png", dpi=_DPI)
