"""Reports of runs against ground truth: scores, Markdown and plots."""

from terrain_odom.app.groundtruth import (
    VARIANTS,
    GroundTruthReport,
    Variant,
    groundtruth_section,
    run_variants,
)
from terrain_odom.reporting.markdown import run_markdown, table

__all__ = [
    "VARIANTS",
    "GroundTruthReport",
    "Variant",
    "groundtruth_section",
    "run_markdown",
    "run_variants",
    "table",
]
