"""sogdd eval matching | sfm: the downstream evaluations.

matching: HPatches mean matching accuracy with D2-Net's protocol (Fig. 10),
also on Oxford and HOMOGR pairs. sfm: COLMAP reconstruction through pycolmap
(Table 2). Detectors are specs NAME[:key=value...], space- or comma-separated;
the pipeline keys remove_border, top_k, desc, desc_size and upright apply to
any detector (see sogdd.evaluation.specs), e.g. the paper's HPatches pipeline
sogdd:levels=5:remove_border=75:top_k=2000.

Results: --out DIR gets matching.json or sfm.json (the --json object), a figure
and a Markdown table; --json prints the object on stdout.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

from ..evaluation.specs import DEFAULT_MATCHING, DEFAULT_SFM, LEARNED_DOWNSTREAM, default_matching, default_sfm
from ._common import (
    HelpFormatter,
    add_detectors_argument,
    add_output_arguments,
    data_path,
    jsonable,
    reference_file,
    reporter,
)

__all__ = ["register"]

_LEARNED_HELP = "; where the learned extra is installed, also " + " ".join(LEARNED_DOWNSTREAM)


def run_matching(args: argparse.Namespace) -> int:
    from ..evaluation.matching import (
        D2NET_EXCLUDED,
        benchmark_info,
        detect_layout,
        evaluate_specs,
        load_published,
        load_sequences,
    )
    from ..evaluation.specs import parse_specs
    from ..report.matching import matching_markdown, plot_mma

    root = data_path(args.root, "homography", "hpatches", what="homography data", flag="--root DIR")
    if not root.is_dir():
        raise ValueError(f"{root}: not a folder")
    layout = detect_layout(root) if args.layout == "auto" else args.layout
    seqs = load_sequences(root, layout, exclude=None if args.no_exclude else D2NET_EXCLUDED,
                          include=args.sequences)
    specs = parse_specs(args.detectors, default_matching())
    out = Path(args.out) if args.out else None
    feat_dir = out / "features" if out is not None and args.save_features else None
    res = evaluate_specs(seqs, specs, feature_dir=feat_dir, progress=reporter(args),
                         max_features=args.max_features, jobs=args.jobs)
    info = benchmark_info(root, layout, seqs)
    budget = {} if args.max_features is None else {"budget": args.max_features}
    obj = jsonable({label: {**r.summary(), **budget, "benchmark": info} for label, r in res.items()})
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        (out / "matching.json").write_text(json.dumps(obj, indent=1))
        (out / "matching.md").write_text(matching_markdown(obj, info))
        pub_path = None if args.no_published else (
            Path(args.published) if args.published else reference_file("hpatches_published_mma.csv"))
        published = load_published(pub_path) if pub_path is not None and pub_path.is_file() else None
        if published and args.published_methods:
            keep = {m.strip() for m in args.published_methods.split(",")}
            published = {k: v for k, v in published.items() if k in keep}
        title = f"MMA, {layout}: {info['n_sequences']} sequences, {info['n_pairs']} pairs"
        plot_mma(obj, out / "mma.png", published=published, full_benchmark=info["full_hpatches"], title=title)
    if args.json:
        sys.stdout.write(json.dumps(obj) + "\n")
    else:
        print(matching_markdown(obj, info), end="")
    return 0


def run_sfm(args: argparse.Namespace) -> int:
    from ..evaluation.sfm import evaluate_sfm
    from ..evaluation.specs import parse_specs
    from ..formats.colmap import require_pycolmap
    from ..report.sfm import sfm_markdown

    require_pycolmap()
    images = data_path(args.images, "multiview", "chair", what="images", flag="--images DIR")
    if not images.is_dir():
        raise ValueError(f"{images}: not a folder")
    dataset = args.dataset or (images.parent.name if images.name == "images" else images.name)
    gt = Path(args.gt_cameras) if args.gt_cameras else None
    if gt is not None and not gt.is_dir():
        raise ValueError(f"{gt}: not a folder")
    specs = parse_specs(args.detectors, default_sfm())
    seeds = parse_seeds(args.seeds) if args.seeds else None
    out = Path(args.out) if args.out else None
    if args.work:
        work_root = Path(args.work)
    elif out is not None:
        work_root = out / "work"
    else:
        work_root = Path(tempfile.mkdtemp(prefix="sogdd-sfm-"))

    def keep(results: dict) -> None:  # what is done survives a later detector's failure
        if out is not None:
            out.mkdir(parents=True, exist_ok=True)
            (out / "sfm.json").write_text(json.dumps(jsonable(results), indent=1))

    obj = jsonable(evaluate_sfm(images, specs, work_root, dataset=dataset, on_result=keep,
                                matcher=args.matcher, gt_cameras=gt, dense=not args.no_dense,
                                num_threads=args.threads, seed=args.seed, seeds=seeds,
                                max_features=args.max_features, jobs=args.jobs,
                                max_runtime_seconds=args.time_limit, progress=reporter(args)))
    table = sfm_markdown(obj, dataset, reference_file("paper_table2.csv"))
    if out is not None:
        (out / "sfm.md").write_text(table)
    if args.json:
        sys.stdout.write(json.dumps(obj) + "\n")
    else:
        print(table, end="")
    return 0


def parse_seeds(text: str) -> list[int]:
    """``"0,1,2"`` -> ``[0, 1, 2]`` (distinct integers; ``ValueError`` otherwise).

    Examples
    --------
    >>> parse_seeds("0, 1,2")
    [0, 1, 2]
    """
    try:
        seeds = [int(t) for t in text.split(",") if t.strip()]
    except ValueError:
        raise ValueError(f"--seeds must be comma-separated integers, got {text!r}") from None
    if not seeds or len(set(seeds)) != len(seeds):
        raise ValueError(f"--seeds must be distinct integers, got {text!r}")
    return seeds


def _positive_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return v


def add_budget_arguments(p: argparse.ArgumentParser) -> None:
    """``--max-features N`` (an equal budget for every detector) and ``--jobs N``."""
    p.add_argument("--max-features", type=_positive_int, metavar="N",
                   help="an equal budget: every detector keeps its N strongest points per image "
                        "(labels gain :top_k=N; a detector with fewer keeps all)")
    p.add_argument("--jobs", type=_positive_int, default=1, help="detectors evaluated in this many processes")


def register(eval_subparsers) -> None:
    """Add ``matching`` and ``sfm`` to ``sogdd eval``."""
    m = eval_subparsers.add_parser(
        "matching", help="HPatches mean matching accuracy (D2-Net protocol; Fig. 10)",
        description=__doc__, formatter_class=HelpFormatter)
    m.add_argument("--root", metavar="DIR",
                   help="folder of sequences [default: $SOGDD_DATA/homography/hpatches]")
    m.add_argument("--layout", choices=("auto", "hpatches", "oxford", "homogr"), default="auto",
                   help="data layout")
    add_detectors_argument(m, " ".join(DEFAULT_MATCHING) + _LEARNED_HELP)
    m.add_argument("--sequences", nargs="+", metavar="NAME", help="only these sequences (names or regexes)")
    m.add_argument("--no-exclude", action="store_true", help="keep D2-Net's 8 excluded HPatches sequences")
    add_output_arguments(m, "matching.json, matching.md and mma.png")
    m.add_argument("--save-features", action="store_true",
                   help="also write every image's features to OUT/features/<seq>/<image>.<method> (D2-Net npz)")
    m.add_argument("--published", metavar="CSV", help="published curves to overlay "
                   "[default: $SOGDD_DATA/../reference/hpatches_published_mma.csv]")
    m.add_argument("--published-methods", metavar="A,B", help="overlay only these published methods")
    m.add_argument("--no-published", action="store_true", help="no published curves on the plot")
    add_budget_arguments(m)
    m.set_defaults(func=run_matching)

    s = eval_subparsers.add_parser(
        "sfm", help="3D reconstruction with COLMAP via pycolmap (Table 2)",
        description=__doc__, formatter_class=HelpFormatter)
    s.add_argument("--images", metavar="DIR", help="image folder [default: $SOGDD_DATA/multiview/chair]")
    add_detectors_argument(s, " ".join(DEFAULT_SFM) + _LEARNED_HELP)
    s.add_argument("--gt-cameras", metavar="DIR", help="Strecha-format GT cameras: report pose errors")
    s.add_argument("--matcher", choices=("colmap", "mnn"), default="colmap",
                   help="COLMAP's exhaustive CPU matcher, or our mutual-NN matches")
    s.add_argument("--dataset", metavar="NAME", help="data set name in tables [default: the folder's name]")
    add_output_arguments(s, "sfm.json and sfm.md (work files in OUT/work)")
    s.add_argument("--work", metavar="DIR",
                   help="database and models here [default: OUT/work or a temp folder]")
    s.add_argument("--no-dense", action="store_true", help="do not try MVS (it needs a CUDA build anyway)")
    s.add_argument("--threads", type=int, default=-1, help="COLMAP threads (-1: all)")
    s.add_argument("--seed", type=int, default=0, help="COLMAP random seed")
    s.add_argument("--seeds", metavar="S,S,...",
                   help="run matching and mapping once per seed with the same features (e.g. 0,1,2): the "
                        "table gives the median and the spread (min-max) over the seeds; overrides --seed")
    add_budget_arguments(s)
    s.add_argument("--time-limit", type=float, default=-1, help="mapper time limit in seconds (-1: none)")
    s.set_defaults(func=run_sfm)
