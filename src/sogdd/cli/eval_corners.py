"""sogdd eval gt | repeatability | resolution: the corner-level evaluations of the paper.

gt: Table 1's protocol (missed, false, Le, F1 against ground-truth corners);
repeatability: Fig. 9's protocol (average repeatability under six transform
families, plus blur beyond the paper; --top-n N adds the fixed-count mode);
resolution: adjacent END- and L-type corner pairs rendered with exact ground truth.
The protocols are in sogdd.evaluation.gt, .repeatability and .resolution;
the tables and figures in sogdd.report.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from ._common import HelpFormatter, add_detectors_argument, add_output_arguments, data_path, print_json

__all__ = ["gt_json", "register"]


def gt_json(rep) -> dict:
    """Per detector: the jointly tuned metrics pooled over all images at top level
    (``missed, false, le, precision, recall, f1, threshold``), plus ``tuned`` (per
    image thresholds, pooled), ``default`` and ``images``."""
    full = rep.to_json()
    out = {}
    for d, v in full["detectors"].items():
        out[d] = {**v["all"]["joint"], "tuned": v["all"]["tuned"],
                  "default": v["all"]["default"], "images": v["images"]}
    return {"delta": rep.delta, "images": rep.images, "n_gt": rep.n_gt,
            "setting": "joint threshold per detector (see tuned/default)", "detectors": out}


def run_gt(args: argparse.Namespace) -> int:
    from ..evaluation.gt import evaluate_gt, find_gt_sets
    from ..evaluation.specs import default_gt_specs, parse_specs
    from ..report.gt import write_gt_outputs
    from ..report.tables import gt_summary_table

    sets = find_gt_sets(data_path(args.data, "corners_gt", what="GT data", flag="--data DIR"))
    specs = parse_specs(args.detectors, default_gt_specs())
    rep = evaluate_gt(sets, specs, delta=args.delta, progress=not args.quiet)
    if args.out:
        write_gt_outputs(rep, sets, Path(args.out))
    if args.json:
        print_json(gt_json(rep))
    else:
        sys.stdout.write(gt_summary_table(rep))
    return 0


def run_repeatability(args: argparse.Namespace) -> int:
    from ..evaluation.repeatability import (
        ALL_FAMILIES,
        FAMILIES,
        evaluate_repeatability,
        load_images,
        top_n_label,
    )
    from ..evaluation.specs import default_fast_specs, parse_specs
    from ..report.plots import repeatability_figure
    from ..report.tables import repeatability_modes_table, repeatability_table

    if args.jobs < 1:
        raise ValueError("--jobs must be >= 1")
    if args.top_n is not None and args.top_n < 1:
        raise ValueError("--top-n must be >= 1")
    folder = data_path(args.images, "repeatability", what="repeatability images", flag="--images DIR")
    images = load_images(folder, limit=args.limit)
    specs = parse_specs(args.detectors, default_fast_specs())
    fams = tuple(f.strip() for f in args.families.split(",")) if args.families else ALL_FAMILIES
    rep = evaluate_repeatability(images, specs, families=fams, quick=args.quick, jobs=args.jobs,
                                 margin=args.margin, progress=not args.quiet, top_n=args.top_n)
    if args.out:
        rep.write(args.out)
        repeatability_figure(rep, Path(args.out) / "repeatability.png", rep.specs)
        if rep.top_n is not None:
            repeatability_figure(rep, Path(args.out) / f"repeatability_top{rep.top_n}.png",
                                 [top_n_label(s, rep.top_n) for s in rep.specs])
    if args.json:
        print_json({"images": rep.images, "quick": rep.quick, "seconds": rep.seconds, "top_n": rep.top_n,
                    "beyond_paper": [f for f in rep.families if f not in FAMILIES],
                    "detectors": rep.summary(), "points": rep.points()})
    else:
        if rep.top_n is not None:
            sys.stdout.write(f"Both modes (default thresholds; threshold off, the {rep.top_n} strongest "
                             "points per image):\n\n" + repeatability_modes_table(rep) + "\n")
        sys.stdout.write(repeatability_table(rep))
        print(f"{len(images)} images, {'quick' if rep.quick else 'full'} grid, "
              f"{rep.seconds:.1f} s", file=sys.stderr)
    return 0


def run_resolution(args: argparse.Namespace) -> int:
    from ..evaluation.resolution import evaluate_resolution, sigma2_specs
    from ..evaluation.specs import parse_specs
    from ..report.plots import resolution_figure, sigma2_figure
    from ..report.tables import resolution_table

    specs = parse_specs(args.detectors, ["all"])
    rep = evaluate_resolution(specs, quick=args.quick, delta=args.delta, mode=args.mode,
                              progress=not args.quiet)
    sweep = None
    if args.sweep_sigma2:
        sweep = evaluate_resolution(sigma2_specs(), quick=args.quick, delta=args.delta,
                                    mode="oracle", progress=not args.quiet)
    if args.out:
        rep.write(args.out)
        resolution_figure(rep, Path(args.out) / f"resolution_{rep.mode}.png")
        if sweep is not None:
            sweep.write(Path(args.out) / "sigma2")
            sigma2_figure(sweep, Path(args.out) / "sigma2" / "sigma2_sweep.png")
    if args.json:
        obj = {"mode": rep.mode, "quick": rep.quick, "delta": rep.delta, "detectors": rep.summary()}
        if sweep is not None:
            obj["sigma2_sweep"] = sweep.summary()
        print_json(obj)
    else:
        sys.stdout.write(resolution_table(rep))
        if sweep is not None:
            sys.stdout.write("\nsigma^2 sweep (oracle threshold):\n" + resolution_table(sweep))
    return 0


def register(eval_subparsers) -> None:
    """Add ``gt``, ``repeatability`` and ``resolution`` to ``sogdd eval``."""
    g = eval_subparsers.add_parser(
        "gt", help="ground-truth accuracy (Table 1's protocol)", formatter_class=HelpFormatter,
        description="Missed, false, Le (eq. 26), precision, recall, F1 against GT corners, at each "
        "detector's default, per-image tuned and jointly tuned thresholds.")
    g.add_argument("--data", metavar="DIR", help="a GT folder (image.<ext> + corners.csv) or a folder of "
                   "them [default: $SOGDD_DATA/corners_gt]")
    g.add_argument("--delta", type=float, default=2.0, help="match radius in px")
    add_detectors_argument(g, "both SOGDD presets with sub-pixel on and off, then every registry name")
    add_output_arguments(g, "gt.md, gt.csv, gt.json and overlays/")
    g.set_defaults(func=run_gt)

    r = eval_subparsers.add_parser(
        "repeatability", help="average repeatability under transforms (Fig. 9's protocol)",
        formatter_class=HelpFormatter,
        description="R_avg (eq. 27) under rotation, scaling, non-uniform scaling, shear, JPEG and noise, "
        "4 px one-to-one matching in the common region.")
    r.add_argument("--images", metavar="DIR", help="folder of images [default: $SOGDD_DATA/repeatability]")
    r.add_argument("--quick", action="store_true", help="a few transforms per family")
    r.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1), help="worker processes")
    r.add_argument("--families", metavar="F,G", help="subset of: rotation,scale,anisotropic,shear,jpeg,noise "
                   "(the paper's six) and blur (Gaussian and motion, beyond the paper) [default: all seven]")
    r.add_argument("--top-n", type=int, default=None, metavar="N",
                   help="also run every detector with its threshold off, keeping its N strongest points "
                   "per image (ranked by response), and report both modes side by side")
    r.add_argument("--limit", type=int, default=None, help="use the first N images only")
    r.add_argument("--margin", type=float, default=0.0,
                   help="border margin (reference px) of the common region")
    add_detectors_argument(r, "sogdd and the fast OpenCV baselines; where the learned extra is installed, "
                              "also xfeat aliked disk")
    add_output_arguments(r, "repeatability.json, the CSVs and repeatability.png")
    r.set_defaults(func=run_repeatability)

    s = eval_subparsers.add_parser(
        "resolution", help="adjacent-corner resolution on rendered END/L-type pairs",
        formatter_class=HelpFormatter,
        description="Fraction of rendered corner pairs (d = 2..12 px) resolved: both corners within "
        "delta and no detection between them.")
    s.add_argument("--quick", action="store_true", help="a small grid")
    s.add_argument("--delta", type=float, default=1.5, help="match radius in px")
    s.add_argument("--mode", choices=("default", "oracle"), default="default",
                   help="detector thresholds: as shipped, or the best per configuration")
    s.add_argument("--sweep-sigma2", action="store_true",
                   help="also sweep sogdd's sigma^2 from 0.8 to 3.0 (oracle threshold)")
    add_detectors_argument(s, "all")
    add_output_arguments(s, "resolution JSON/CSV and figures")
    s.set_defaults(func=run_resolution)
