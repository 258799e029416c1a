"""``sogdd eval``: the paper's evaluations on any detector of the registry.

Sub-commands: ``gt`` (Table 1's protocol), ``repeatability`` (Fig. 9's),
``resolution`` (adjacent corners). Detectors are comma-separated specs,
``NAME`` or ``NAME:key=value`` (``sogdd:subpixel=false``); ``all`` means every
registry name. Data paths default to ``$SOGDD_DATA`` or ``../shared/data``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from pathlib import Path

__all__ = ["register", "data_root"]


def data_root() -> Path | None:
    """``$SOGDD_DATA``, else ``../shared/data`` relative to the working directory if it exists."""
    env = os.environ.get("SOGDD_DATA")
    if env:
        return Path(env)
    p = Path("..") / "shared" / "data"
    return p if p.is_dir() else None


def _default_sub(sub: str) -> Path | None:
    root = data_root()
    return root / sub if root is not None and (root / sub).is_dir() else None


def jsonable(obj):
    """``obj`` with non-finite floats as None and numpy scalars as Python numbers."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if hasattr(obj, "item") and callable(obj.item):  # numpy scalars
        return jsonable(obj.item())
    return obj


def print_json(obj) -> None:
    sys.stdout.write(json.dumps(jsonable(obj)) + "\n")


def _progress(args) -> bool:
    return not getattr(args, "no_progress", False)


# ---------------------------------------------------------------- gt
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


def run_gt(args) -> int:
    from ..evaluation.detectors import default_gt_specs, parse_specs
    from ..evaluation.gt_accuracy import evaluate_gt
    from ..evaluation.gt_data import find_gt_sets
    from ..report.results_page import write_gt_outputs

    data = Path(args.data) if args.data else _default_sub("corners_gt")
    if data is None:
        raise ValueError("no GT data: pass --data DIR or set SOGDD_DATA")
    sets = find_gt_sets(data)
    specs = parse_specs(args.detectors, default_gt_specs())
    rep = evaluate_gt(sets, specs, delta=args.delta, progress=_progress(args))
    if args.out:
        write_gt_outputs(rep, sets, Path(args.out))
    if args.json:
        print_json(gt_json(rep))
    else:
        from ..report.tables import gt_summary_table

        sys.stdout.write(gt_summary_table(rep))
    return 0


# ---------------------------------------------------------------- repeatability
def run_repeatability(args) -> int:
    from ..evaluation.detectors import default_fast_specs, parse_specs
    from ..evaluation.repeatability import evaluate_repeatability, load_images
    from ..evaluation.transforms import FAMILIES
    from ..report.plots import repeatability_figure
    from ..report.tables import repeatability_table

    folder = args.images if args.images else _default_sub("repeatability")
    images = load_images(folder, limit=args.limit)
    specs = parse_specs(args.detectors, default_fast_specs())
    fams = tuple(f.strip() for f in args.families.split(",")) if args.families else FAMILIES
    if args.jobs < 1:
        raise ValueError("--jobs must be >= 1")
    rep = evaluate_repeatability(images, specs, families=fams, quick=args.quick, jobs=args.jobs,
                                 margin=args.margin, progress=_progress(args))
    if args.out:
        rep.write(args.out)
        repeatability_figure(rep, Path(args.out) / "repeatability.png")
    if args.json:
        print_json({"images": rep.images, "quick": rep.quick, "seconds": rep.seconds,
                    "detectors": rep.summary()})
    else:
        sys.stdout.write(repeatability_table(rep))
        print(f"{len(images)} images, {'quick' if rep.quick else 'full'} grid, "
              f"{rep.seconds:.1f} s", file=sys.stderr)
    return 0


# ---------------------------------------------------------------- resolution
def run_resolution(args) -> int:
    from ..evaluation.detectors import DetectorSpec, parse_specs, registry_names
    from ..evaluation.resolution import evaluate_resolution, sigma2_specs
    from ..report.plots import resolution_figure, sigma2_figure
    from ..report.tables import resolution_table

    specs = parse_specs(args.detectors, [DetectorSpec(n) for n in registry_names()])
    rep = evaluate_resolution(specs, quick=args.quick, delta=args.delta, mode=args.mode,
                              progress=_progress(args))
    sweep = None
    if args.sweep_sigma2:
        sweep = evaluate_resolution(sigma2_specs(), quick=args.quick, delta=args.delta,
                                    mode="oracle", progress=_progress(args))
    if args.out:
        rep.write(args.out)
        resolution_figure(rep, Path(args.out) / f"resolution_{rep.mode}.png")
        if sweep is not None:
            files = sweep.write(Path(args.out) / "sigma2")
            sigma2_figure(sweep, Path(args.out) / "sigma2" / "sigma2_sweep.png")
            del files
    if args.json:
        obj = {"mode": rep.mode, "quick": rep.quick, "delta": rep.delta,
               "detectors": rep.summary()}
        if sweep is not None:
            obj["sigma2_sweep"] = sweep.summary()
        print_json(obj)
    else:
        sys.stdout.write(resolution_table(rep))
        if sweep is not None:
            sys.stdout.write("\nsigma^2 sweep (oracle threshold):\n" + resolution_table(sweep))
    return 0


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--detectors", metavar="A,B,...",
                   help="detector specs NAME[:key=value...], comma-separated; 'all' = registry")
    p.add_argument("--out", metavar="DIR", help="write tables, JSON/CSV and figures here")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")


def register(subparsers) -> None:
    ev = subparsers.add_parser("eval", help="evaluate detectors (GT accuracy, repeatability, "
                               "adjacent-corner resolution)", description=__doc__,
                               formatter_class=argparse.RawDescriptionHelpFormatter)
    eval_subparsers = ev.add_subparsers(dest="eval_command", metavar="EVALUATION")
    ev.set_defaults(func=lambda args: (ev.print_help(sys.stderr), 2)[1])

    g = eval_subparsers.add_parser(
        "gt", help="ground-truth accuracy (Table 1's protocol)",
        description="Missed, false, Le (eq. 26), precision, recall, F1 against GT corners, at "
        "each detector's default, per-image tuned and jointly tuned thresholds.")
    g.add_argument("--data", metavar="DIR",
                   help="a GT folder (image.<ext> + corners.csv) or a folder of them "
                   "[default: $SOGDD_DATA/corners_gt]")
    g.add_argument("--delta", type=float, default=2.0, help="match radius in px [2]")
    _common(g)
    g.set_defaults(func=run_gt)

    r = eval_subparsers.add_parser(
        "repeatability", help="average repeatability under transforms (Fig. 9's protocol)",
        description="R_avg (eq. 27) under rotation, scaling, non-uniform scaling, shear, JPEG "
        "and noise, 4 px one-to-one matching in the common region.")
    r.add_argument("--images", metavar="DIR",
                   help="folder of images [default: $SOGDD_DATA/repeatability, else "
                   "scikit-image's sample images]")
    r.add_argument("--quick", action="store_true", help="a few transforms per family")
    r.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1),
                   help="worker processes [min(2, cores)]")
    r.add_argument("--families", metavar="F,G", help="subset of: rotation,scale,anisotropic,"
                   "shear,jpeg,noise")
    r.add_argument("--limit", type=int, default=None, help="use the first N images only")
    r.add_argument("--margin", type=float, default=0.0,
                   help="border margin (reference px) of the common region [0]")
    _common(r)
    r.set_defaults(func=run_repeatability)

    s = eval_subparsers.add_parser(
        "resolution", help="adjacent-corner resolution on rendered END/L-type pairs",
        description="Fraction of rendered corner pairs (d = 2..12 px) resolved: both corners "
        "within delta and no detection between them.")
    s.add_argument("--quick", action="store_true", help="a small grid")
    s.add_argument("--delta", type=float, default=1.5, help="match radius in px [1.5]")
    s.add_argument("--mode", choices=("default", "oracle"), default="default",
                   help="detector thresholds: as shipped, or the best per configuration")
    s.add_argument("--sweep-sigma2", action="store_true",
                   help="also sweep sogdd's sigma^2 from 0.8 to 3.0 (oracle threshold)")
    _common(s)
    s.set_defaults(func=run_resolution)

    try:
        from .eval_downstream import register_eval

        register_eval(eval_subparsers)
    except ImportError:
        pass

    from .eval_chessboard import register_chessboard

    register_chessboard(eval_subparsers)
