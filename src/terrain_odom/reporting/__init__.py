"""Human-readable output of runs: Markdown reports and PNG plots (no computation)."""

from terrain_odom.reporting.markdown import run_markdown, table

__all__ = ["run_markdown", "table"]
