"""Reporting: every table (Markdown/CSV) and figure of the evaluations, and the results page.

:mod:`.tables` and :mod:`.plots` for GT, repeatability and resolution;
:mod:`.gt` (Table 1 files and overlay montages, drawn by :mod:`.overlays`);
:mod:`.matching` (MMA table and curves); :mod:`.sfm` (Table 2);
:mod:`.results_page` (``sogdd report``).
"""

from .tables import gt_summary_table, gt_table, markdown_table, repeatability_table, resolution_table

__all__ = ["gt_summary_table", "gt_table", "markdown_table", "repeatability_table",
           "resolution_table"]
