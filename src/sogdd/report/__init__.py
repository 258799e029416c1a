"""Reporting: tables (Markdown/CSV), figures and the results page of ``sogdd report``."""

from .tables import gt_summary_table, gt_table, markdown_table, repeatability_table, resolution_table

__all__ = ["gt_summary_table", "gt_table", "markdown_table", "repeatability_table",
           "resolution_table"]
