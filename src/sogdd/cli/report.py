"""sogdd report: run the fast evaluations and write the results page.

GT accuracy, repeatability (quick grid unless --full), dense checkerboards
(full grid unless --chessboard-quick) and Fig. 1 are run on the benchmark
data. Adjacent-corner resolution is read from cached full-grid runs
(figures/resolution_full/ next to the page, or --resolution-runs DIR; made by
`sogdd eval resolution --out DIR` and `sogdd eval resolution --mode oracle
--sweep-sigma2 --out DIR`) where they exist, else run on the quick grid (the
full grid with --full). The matching and SfM runs already written under
figures/downstream/ next to the page are included as they are, and so are the
learned detectors' repeatability runs under figures/repeatability_learned/
(or --learned-runs DIR; made by `python benchmarks/bench_learned.py
repeatability`) where their protocol is the one run here.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from ._common import check_input_files, check_not_inputs, data_path

__all__ = ["configure"]


def run(args: argparse.Namespace) -> int:
    from ..report.results_page import build_report

    check_input_files([f for f in (args.paper, args.readme) if f], "a text file")
    check_not_inputs([("--out", args.out)], [args.paper, args.readme])
    data = data_path(args.data, what="benchmark data", flag="--data DIR")
    for sub in ("corners_gt", "repeatability"):
        if not (data / sub).is_dir():
            raise ValueError(f"{data}: has no {sub}/ folder")
    if args.resolution_runs and not Path(args.resolution_runs).is_dir():
        raise ValueError(f"--resolution-runs: {args.resolution_runs} is not a folder")
    if args.learned_runs and not Path(args.learned_runs).is_dir():
        raise ValueError(f"--learned-runs: {args.learned_runs} is not a folder")
    out = build_report(args.out, data, full=args.full, jobs=args.jobs, paper_csv=args.paper,
                       progress=not args.quiet, resolution_runs=args.resolution_runs,
                       chessboard_quick=args.chessboard_quick, readme=args.readme,
                       learned_runs=args.learned_runs)
    print(out)
    return 0


def configure(p: argparse.ArgumentParser) -> None:
    """The ``report`` command's arguments."""
    p.description = __doc__
    p.add_argument("--out", default="docs/results.md",
                   help="the page; figures go to figures/results/ next to it")
    p.add_argument("--data", metavar="DIR", help="benchmark data root [default: $SOGDD_DATA or ../shared/data]")
    p.add_argument("--paper", metavar="CSV", help="the paper's Table 1 "
                   "[default: DATA/../reference/paper_table1.csv]")
    p.add_argument("--full", action="store_true",
                   help="the paper's full repeatability grid and the full resolution grid (run, not cached)")
    p.add_argument("--resolution-runs", metavar="DIR",
                   help="cached resolution runs [default: figures/resolution_full next to the page]")
    p.add_argument("--learned-runs", metavar="DIR",
                   help="cached repeatability runs of the learned detectors "
                   "[default: figures/repeatability_learned next to the page]")
    p.add_argument("--chessboard-quick", action="store_true", help="the checkerboards' quick grid")
    p.add_argument("--readme", metavar="PATH",
                   help="also rewrite this page's result blocks from the same run "
                   "(<!-- results:NAME --> ... <!-- /results:NAME -->; docs/reproducing/index.md)")
    p.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1), help="worker processes")
    p.add_argument("--quiet", "--no-progress", dest="quiet", action="store_true", help="no progress on stderr")
    p.set_defaults(func=run)
