"""The ground-truth section of a run's report as a typed record (``run --groundtruth``).

Built by :func:`terrain_odom.app.groundtruth.groundtruth_section` from the
scores of :mod:`terrain_odom.evaluation.groundtruth`;
:meth:`GroundTruthSection.to_dict` is the ``groundtruth`` entry of
``report.json`` and :func:`~terrain_odom.reporting.markdown.run_markdown`
renders its attributes.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

from terrain_odom.evaluation.groundtruth import (
    FrameAccuracy,
    FrameTime,
    ModelOdometry,
    Reconvergence,
)
from terrain_odom.records import TerrainChange

__all__ = ["FRAME_TRUTH", "GroundTruthSettings", "FrameScores", "GroundTruthSection"]

FRAME_TRUTH = "terrain under the true robot once it has travelled the frame's ahead_m"
"""What a frame's true terrain is (``frames.truth`` of the section)."""


@dataclass(frozen=True)
class GroundTruthSettings:
    """How the run was scored: window length, ICR band, reset timing, what frames were classified.

    ``classification``: ``roi``, ``whole frame``, or None without frames.
    """

    horizon_m: float
    icr_tolerance_m: float
    reset_at: str
    classification: str | None

    def to_dict(self) -> dict[str, Any]:
        """Return the ``settings`` entry."""
        return {
            "horizon_m": self.horizon_m,
            "icr_tolerance_m": self.icr_tolerance_m,
            "reset_at": self.reset_at,
            "classification": self.classification,
        }


@dataclass(frozen=True)
class FrameScores:
    """A camera run's frames against their true terrain: accuracy and times per true terrain.

    ``classification_time`` is the feature extraction and the KNN vote.
    """

    accuracy: FrameAccuracy
    feature_time: dict[str, FrameTime]
    classification_time: dict[str, FrameTime]

    def to_dict(self) -> dict[str, Any]:
        """Return the ``frames`` entry."""
        return {
            "truth": FRAME_TRUTH,
            "accuracy": self.accuracy.to_dict(),
            "feature_time": {k: t.to_dict() for k, t in self.feature_time.items()},
            "classification_time": {k: t.to_dict() for k, t in self.classification_time.items()},
        }


@dataclass(frozen=True)
class GroundTruthSection:
    """A run scored against ground truth: ``groundtruth`` of ``report.json``.

    Attributes
    ----------
    settings : GroundTruthSettings
    true_changes : tuple of (float, str, str)
        The true terrain changes within the log: ``(t, from, to)``.
    odometry : dict of str to ModelOdometry
        Per model (ideal differential drive and the filter variants).
    reconvergence : dict of str to list of Reconvergence
        Per filter variant, one per true change.
    resets : dict of str to list of TerrainChange
        Per filter variant, the terrain changes it applied.
    frames : FrameScores or None
        With frames (a camera run).
    """

    settings: GroundTruthSettings
    true_changes: tuple[tuple[float, str, str], ...]
    odometry: dict[str, ModelOdometry]
    reconvergence: dict[str, list[Reconvergence]]
    resets: dict[str, list[TerrainChange]]
    frames: FrameScores | None = None

    def to_dict(self) -> dict[str, Any]:
        """Return the ``groundtruth`` entry."""
        out: dict[str, Any] = {
            "settings": self.settings.to_dict(),
            "true_changes": [{"t": t, "from": a, "to": new} for t, a, new in self.true_changes],
            "odometry": {name: m.to_dict() for name, m in self.odometry.items()},
            "reconvergence": {
                name: [c.to_dict() for c in changes] for name, changes in self.reconvergence.items()
            },
            "resets": {name: [asdict(c) for c in changes] for name, changes in self.resets.items()},
        }
        if self.frames is not None:
            out["frames"] = self.frames.to_dict()
        return out
