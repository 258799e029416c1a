"""``sogdd theory``: the paper's corner theory, computed (figures, sigma ranges, tables)."""

from __future__ import annotations

import argparse
import json
import math


def _figures(args: argparse.Namespace) -> int:
    from ..theory.figures import write_figures  # matplotlib only when needed

    for path in write_figures(args.out, lattice=not args.no_lattice):
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


def register(sub) -> None:
    p = sub.add_parser("theory", help="the paper's corner theory: figures, sigma ranges, tables",
                       description=__doc__)
    tsub = p.add_subparsers(dest="theory_command", metavar="SUBCOMMAND")
    p.set_defaults(func=lambda args: (p.print_help(), 2)[1])

    f = tsub.add_parser("figures", help="write the theory figures (PNG)")
    f.add_argument("--out", required=True, metavar="DIR", help="output folder (created if needed)")
    f.add_argument("--no-lattice", action="store_true", help="skip the (slower) lattice figure")
    f.set_defaults(func=_figures)

    s = tsub.add_parser("sigma-range", help="sigma intervals where the corner out-responds the edge (eq. 15)")
    s.add_argument("--model", required=True, choices=["end", "l"])
    s.add_argument("--d", required=True, type=_positive)
    s.add_argument("--alpha", required=True, type=float, help="radians, in (0, pi/2)")
    s.add_argument("--beta", type=float, help="radians, in (0, pi/2); END only")
    s.add_argument("--sigma-min", type=_positive, default=0.3)
    s.add_argument("--sigma-max", type=_positive, default=6.0)
    s.add_argument("--method", choices=["exact", "quadrature", "paper"], default="exact")
    s.add_argument("--json", action="store_true")
    s.set_defaults(func=_sigma_range)

    t = tsub.add_parser("tables", help="print the markdown tables of docs/theory.md")
    t.add_argument("--no-quadrature", action="store_true", help="skip the quadrature column (faster)")
    t.set_defaults(func=_tables)
