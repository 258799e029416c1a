"""``sogdd report``: run the fast evaluations and write the results page."""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["register"]


def run(args) -> int:
    from ..report.results_page import build_report
    from .eval import data_root

    data = Path(args.data) if args.data else data_root()
    if data is None or not data.is_dir():
        raise ValueError("no benchmark data: pass --data DIR or set SOGDD_DATA")
    if not (data / "corners_gt").is_dir():
        raise ValueError(f"{data}: has no corners_gt/ folder")
    out = build_report(args.out, data, full=args.full, jobs=args.jobs, paper_csv=args.paper,
                       progress=not args.no_progress)
    print(out)
    return 0


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "report", help="run the evaluations and write the results page (Markdown + figures)")
    p.add_argument("--out", default="docs/results.md", help="the page [docs/results.md]; "
                   "figures go to figures/results/ next to it")
    p.add_argument("--data", metavar="DIR", help="benchmark data root [$SOGDD_DATA or "
                   "../shared/data]")
    p.add_argument("--paper", metavar="CSV", help="the paper's Table 1 "
                   "[DATA/../reference/paper_table1.csv]")
    p.add_argument("--full", action="store_true",
                   help="the paper's full repeatability grid and the full resolution grid")
    p.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1))
    p.add_argument("--no-progress", action="store_true")
    p.set_defaults(func=run)
