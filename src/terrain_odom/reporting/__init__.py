"""Reports of runs against ground truth: scores, Markdown and plots."""

from terrain_odom.reporting.markdown import run_markdown, table
from terrain_odom.reporting.run_report import (
    VARIANTS,
    GroundTruthReport,
    Variant,
    groundtruth_section,
    run_variants,
)

__all__ = [
    "VARIANTS",
    "GroundTruthReport",
    "Variant",
    "groundtruth_section",
    "run_markdown",
    "run_variants",
    "table",
]
