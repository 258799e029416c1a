"""sogdd theory: the paper's corner theory, computed (figures, sigma ranges, tables)."""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from pathlib import Path

from ._common import HelpFormatter, output_folder


def _fig1_data(args: argparse.Namespace) -> Path | None:
    """The data root for Fig. 1: ``--data``, ``$SOGDD_DATA`` or ``../shared/data``; None to skip."""
    if args.no_fig1:
        return None
    if args.data is not None:
        root = Path(args.data)
        if not (root / "corners_gt").is_dir():
            raise ValueError(f"--data {root}: no corners_gt folder there")
        return root
    env = os.environ.get("SOGDD_DATA")
    for root in ([Path(env)] if env else []) + [Path("..") / "shared" / "data"]:
        if (root / "corners_gt").is_dir():
            return root
    print("sogdd: note: Fig. 1 skipped: no benchmark data (pass --data DIR or set SOGDD_DATA)",
          file=sys.stderr)
    return None


def _figures(args: argparse.Namespace) -> int:
    from ..theory.figures import write_figures  # matplotlib only when needed

    for path in write_figures(args.out, lattice=not args.no_lattice, data=_fig1_data(args)):
        print(path)
    return 0


def _sigma_range(args: argparse.Namespace) -> int:
    from ..theory.models import make_model
    from ..theory.scale_rule import scan_sigma

    if args.model == "end" and args.beta is None:
        raise ValueError("--beta is required for --model end")
    m = make_model(args.model, d=args.d, alpha=args.alpha, beta=args.beta)
    sc = scan_sigma(m, args.sigma_min, args.sigma_max, args.method)
    if args.json:
        print(json.dumps({
            "model": args.model, "d": args.d, "alpha": args.alpha, "beta": m.beta,
            "method": args.method, "sigma_min": args.sigma_min, "sigma_max": args.sigma_max,
            "intervals": [list(iv) for iv in sc.intervals], "crossings": sc.crossings,
        }))
        return 0
    geo = f"d={args.d:g}, alpha={args.alpha:g}" + (f", beta={m.beta:g}" if m.beta is not None else "")
    print(f"{args.model.upper()} model, {geo}, method={args.method}")
    print(f"corner wins (E1 > E2) for sigma in [{args.sigma_min:g}, {args.sigma_max:g}]:")
    if not sc.intervals:
        print("  nowhere")
    for lo, hi in sc.intervals:
        print(f"  ({lo:.6f}, {hi:.6f})   sigma^2 in ({lo * lo:.6f}, {hi * hi:.6f})")
    for c in sc.crossings:
        print(f"crossing E1 = E2 at sigma = {c:.6f} (sigma^2 = {c * c:.6f})")
    return 0


def _tables(args: argparse.Namespace) -> int:
    from ..theory.tables import all_tables

    print(all_tables(quadrature=not args.no_quadrature), end="")
    return 0


def _positive(text: str) -> float:
    v = float(text)
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"must be a positive number: {text!r}")
    return v


def configure(p: argparse.ArgumentParser) -> None:
    """The ``theory`` command and its sub-commands."""
    p.description = __doc__
    tsub = p.add_subparsers(dest="theory_command", metavar="SUBCOMMAND")
    p.set_defaults(func=lambda args: (p.print_help(), 2)[1])

    f = tsub.add_parser("figures", help="write the theory figures (PNG)", formatter_class=HelpFormatter)
    f.add_argument("--out", required=True, metavar="DIR", type=output_folder,
                   help="output folder (created if needed)")
    f.add_argument("--no-lattice", action="store_true", help="skip the (slower) lattice figure")
    f.add_argument("--data", metavar="DIR", help="benchmark data root for Fig. 1 (reads corners_gt/geometric) "
                   "[$SOGDD_DATA or ../shared/data; Fig. 1 is skipped, with a note, where there is none]")
    f.add_argument("--no-fig1", action="store_true", help="skip Fig. 1 (the real-image figure)")
    f.set_defaults(func=_figures)

    s = tsub.add_parser("sigma-range", help="sigma intervals where the corner out-responds the edge (eq. 15)",
                        formatter_class=HelpFormatter)
    s.add_argument("--model", required=True, choices=["end", "l"], help="END-type (eq. 3) or L-type (eq. 11)")
    s.add_argument("--d", required=True, type=_positive, help="distance between the two corners (px)")
    s.add_argument("--alpha", required=True, type=float, help="radians, in (0, pi/2)")
    s.add_argument("--beta", type=float, help="radians, in (0, pi/2); END only")
    s.add_argument("--sigma-min", type=_positive, default=0.3, help="smallest sigma scanned")
    s.add_argument("--sigma-max", type=_positive, default=6.0, help="largest sigma scanned")
    s.add_argument("--method", choices=["exact", "quadrature", "paper"], default="exact",
                   help="closed form, numerical quadrature, or the paper's printed formulas")
    s.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    s.set_defaults(func=_sigma_range)

    t = tsub.add_parser("tables", help="print the markdown tables of docs/theory.md",
                        formatter_class=HelpFormatter)
    t.add_argument("--no-quadrature", action="store_true", help="skip the quadrature column (faster)")
    t.set_defaults(func=_tables)
