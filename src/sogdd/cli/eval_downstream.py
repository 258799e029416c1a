"""``sogdd eval matching`` and ``sogdd eval sfm``: the downstream evaluations.

``matching``: HPatches mean matching accuracy with D2-Net's protocol (Fig. 10),
also on Oxford and HOMOGR pairs. ``sfm``: COLMAP reconstruction through pycolmap
(Table 2). Detectors are specs ``NAME[:key=value...]``, space- or
comma-separated; the pipeline keys ``remove_border``, ``top_k``, ``desc``,
``desc_size`` and ``upright`` apply to any detector (see
:mod:`sogdd.evaluation.matching_common`), e.g. the paper's HPatches pipeline
``sogdd:levels=5:remove_border=75:top_k=2000``.

Results: ``--out DIR`` gets ``matching.json`` / ``sfm.json`` (the ``--json``
object), a figure and a Markdown table; ``--json`` prints the object on stdout.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .eval import data_root, jsonable

__all__ = ["register_eval", "DEFAULT_MATCHING", "DEFAULT_SFM"]

# Defaults: SOGDD plain and with the paper's pipeline, and the registry's fast baselines.
DEFAULT_MATCHING = [
    "sogdd",
    "sogdd:levels=5:remove_border=75",
    "sogdd:levels=5:remove_border=75:top_k=2000",
    "sift", "harris", "shi-tomasi", "fast", "orb", "akaze",
]
# SfM: the paper preset's threshold (1e9) leaves ~200 corners on a 6 MP photo, too
# few for SfM, so SOGDD runs with the threshold off and its strongest 8000 corners.
DEFAULT_SFM = ["sogdd:threshold=none:top_k=8000", "sift"]


def _reference(name: str) -> Path | None:
    root = data_root()
    if root is None:
        return None
    p = root.parent / "reference" / name
    return p if p.is_file() else None


def _specs(items: list[str] | None, default: list[str]):
    from ..evaluation.matching_common import build_detector, parse_feature_spec

    texts = []
    for item in items or []:
        texts += [t.strip() for t in item.split(",") if t.strip()]
    if not texts:
        texts = list(default)
    if texts == ["all"] or "all" in texts:
        from .. import baselines  # type: ignore[attr-defined]

        texts = [t for t in texts if t != "all"] + [n for n in baselines.available() if n not in texts]
    specs = []
    for t in texts:
        spec = parse_feature_spec(t)
        try:
            build_detector(spec.name, **spec.params)  # fail before any work
        except ValueError:
            if items:
                raise
            continue  # a default detector that this installation lacks
        specs.append(spec)
    return specs


def _say(args):
    if getattr(args, "quiet", False):
        return None
    return lambda msg: print(msg, file=sys.stderr, flush=True)


# ---------------------------------------------------------------- matching
def matching_markdown(results: dict, info: dict) -> str:
    """Markdown table of a matching run: MMA at 1, 3, 5, 10 px per split, features, matches."""
    full = "the full D2-Net HPatches benchmark" if info["full_hpatches"] else "NOT the full HPatches benchmark"
    lines = [
        f"Sequences: {info['n_sequences']} ({info['n_illumination']} illumination, "
        f"{info['n_viewpoint']} viewpoint), {info['n_pairs']} pairs; layout {info['layout']}; {full}. "
        f"Descriptor: {info['descriptor']}.",
        "",
        "| detector | split | MMA@1 | MMA@3 | MMA@5 | MMA@10 | features | matches |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for label, s in results.items():
        n_all = s["pairs"]["overall"]
        for split, curve in s["mma"].items():
            if curve is None:
                continue
            if split != "overall" and s["pairs"][split] == n_all:
                continue  # the only split present: its row would repeat the overall row
            name = split
            if split == "overall":
                only = [k for k in ("illumination", "viewpoint") if s["pairs"][k] == n_all]
                name = f"overall (all {only[0]})" if only else "overall"
            lines.append(
                f"| `{label}` | {name}, {s['pairs'][split]} pairs | {curve[0]:.3f} | {curve[2]:.3f} | "
                f"{curve[4]:.3f} | {curve[9]:.3f} | {s['features']:.0f} | {s['matches']:.0f} |"
            )
    return "\n".join(lines) + "\n"


def run_matching(args) -> int:
    from ..evaluation.homography_data import D2NET_EXCLUDED, detect_layout, load_sequences
    from ..evaluation.matching_mma import benchmark_info, evaluate_specs, load_published, plot_mma

    root = Path(args.root) if args.root else None
    if root is None:
        d = data_root()
        root = d / "homography" / "hpatches" if d is not None else None
    if root is None or not root.is_dir():
        raise ValueError("no homography data: pass --root DIR or set SOGDD_DATA")
    layout = detect_layout(root) if args.layout == "auto" else args.layout
    seqs = load_sequences(root, layout, exclude=None if args.no_exclude else D2NET_EXCLUDED,
                          include=args.sequences)
    specs = _specs(args.detectors, DEFAULT_MATCHING)
    out = Path(args.out) if args.out else None
    feat_dir = out / "features" if out is not None and args.save_features else None
    res = evaluate_specs(seqs, specs, feature_dir=feat_dir, progress=_say(args))
    info = benchmark_info(root, layout, seqs)
    obj = {label: {**r.summary(), "benchmark": info} for label, r in res.items()}
    obj = jsonable(obj)
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        (out / "matching.json").write_text(json.dumps(obj, indent=1))
        (out / "matching.md").write_text(matching_markdown(obj, info))
        pub_path = None if args.no_published else (Path(args.published) if args.published
                                                   else _reference("hpatches_published_mma.csv"))
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


# ---------------------------------------------------------------- sfm
def _paper_rows(dataset: str) -> list[dict]:
    path = _reference("paper_table2.csv")
    if path is None:
        return []
    import csv

    aliases = {"fountain-p11": "Fountain", "herz-jesus-p8": "Herzjesu"}
    want = aliases.get(dataset.lower(), dataset)
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(line for line in fh if not line.startswith("#")))
    return [r for r in rows if r["dataset"].lower() == want.lower()]


def _fmt(v, nd=2):
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.{nd}f}"
    return str(v)


def sfm_markdown(obj: dict, dataset: str) -> str:
    """Table 2-style Markdown: our rows, then the paper's rows for the same data set."""
    lines = [
        f"Data set: {dataset}",
        "",
        "| method | source | #reg. images | #sparse points | #dense points | track length | reproj. error (px) "
        "| features/img | seconds | rot. err. (deg, median) | pos. err. (median) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for label, r in obj.items():
        pe = r.get("pose_errors") or {}
        dense = r.get("dense_points")
        gpu = r.get("dense_points_gpu")  # added by a separate run on a CUDA machine, if any
        if gpu:
            dense = f"{gpu['points']} (CUDA run, images <= {gpu['max_image_size']} px)"
        lines.append(
            f"| `{label}` | this run | {r['registered']}/{r['images']} | {r['points']} | "
            f"{dense} | "
            f"{_fmt(r.get('track_length'))} | {_fmt(r.get('reproj_error'))} | {r['features']:.0f} | "
            f"{_fmt(r.get('seconds'), 1)} | {_fmt(pe.get('rotation_deg_median'), 3)} | "
            f"{_fmt(pe.get('position_median'), 4)} |"
        )
    for p in _paper_rows(dataset):
        lines.append(
            f"| {p['method']} | paper, Table 2 | {p['registered']}/{p['images']} | {p['sparse_points']} | "
            f"{p['dense_points']} | {p['track_length']} | {p['reproj_error_px']} | - | - | - | - |"
        )
    return "\n".join(lines) + "\n"


def run_sfm_cmd(args) -> int:
    from ..evaluation.colmap_io import require_pycolmap
    from ..evaluation.sfm import run_sfm

    require_pycolmap()
    images = Path(args.images) if args.images else None
    if images is None:
        d = data_root()
        images = d / "multiview" / "chair" if d is not None else None
    if images is None or not images.is_dir():
        raise ValueError("no images: pass --images DIR or set SOGDD_DATA")
    dataset = args.dataset or (images.parent.name if images.name == "images" else images.name)
    gt = Path(args.gt_cameras) if args.gt_cameras else None
    if gt is not None and not gt.is_dir():
        raise ValueError(f"{gt}: not a folder")
    specs = _specs(args.detectors, DEFAULT_SFM)
    out = Path(args.out) if args.out else None
    if args.work:
        work_root = Path(args.work)
    elif out is not None:
        work_root = out / "work"
    else:
        import tempfile

        work_root = Path(tempfile.mkdtemp(prefix="sogdd-sfm-"))
    obj = {}
    for spec in specs:
        safe = "".join(ch if ch.isalnum() or ch in "-_=" else "_" for ch in spec.label)
        r = run_sfm(images, spec, work_root / f"{dataset}-{safe}", matcher=args.matcher, gt_cameras=gt,
                    dense=not args.no_dense, num_threads=args.threads, seed=args.seed,
                    max_runtime_seconds=args.time_limit, progress=_say(args))
        r["dataset"] = dataset
        obj[spec.label] = jsonable(r)
        if out is not None:  # keep what is done if a later detector fails or is stopped
            out.mkdir(parents=True, exist_ok=True)
            (out / "sfm.json").write_text(json.dumps(obj, indent=1))
    if out is not None:
        (out / "sfm.md").write_text(sfm_markdown(obj, dataset))
    if args.json:
        sys.stdout.write(json.dumps(obj) + "\n")
    else:
        print(sfm_markdown(obj, dataset), end="")
    return 0


# ---------------------------------------------------------------- parsers
def register_eval(eval_subparsers) -> None:
    """Add the ``matching`` and ``sfm`` sub-commands to ``sogdd eval``."""
    m = eval_subparsers.add_parser(
        "matching", help="HPatches mean matching accuracy (D2-Net protocol; Fig. 10)",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    m.add_argument("--root", metavar="DIR", help="folder of sequences [$SOGDD_DATA/homography/hpatches]")
    m.add_argument("--layout", choices=("auto", "hpatches", "oxford", "homogr"), default="auto")
    m.add_argument("--detectors", nargs="+", metavar="SPEC",
                   help="detector specs, space- or comma-separated; 'all' = every registry name "
                        f"[{' '.join(DEFAULT_MATCHING)}]")
    m.add_argument("--sequences", nargs="+", metavar="NAME", help="only these sequences (names or regexes)")
    m.add_argument("--no-exclude", action="store_true", help="keep D2-Net's 8 excluded HPatches sequences")
    m.add_argument("--out", metavar="DIR", help="write matching.json, matching.md and mma.png here")
    m.add_argument("--save-features", action="store_true",
                   help="also write every image's features to OUT/features/<seq>/<image>.<method> (D2-Net npz)")
    m.add_argument("--published", metavar="CSV", help="published curves to overlay "
                   "[../shared/reference/hpatches_published_mma.csv]")
    m.add_argument("--published-methods", metavar="A,B", help="overlay only these published methods")
    m.add_argument("--no-published", action="store_true", help="no published curves on the plot")
    m.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    m.add_argument("--quiet", action="store_true", help="no progress on stderr")
    m.set_defaults(func=run_matching)

    s = eval_subparsers.add_parser(
        "sfm", help="3D reconstruction with COLMAP via pycolmap (Table 2)",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    s.add_argument("--images", metavar="DIR", help="image folder [$SOGDD_DATA/multiview/chair]")
    s.add_argument("--detectors", nargs="+", metavar="SPEC", help=f"detector specs [{' '.join(DEFAULT_SFM)}]")
    s.add_argument("--gt-cameras", metavar="DIR", help="Strecha-format GT cameras: report pose errors")
    s.add_argument("--matcher", choices=("colmap", "mnn"), default="colmap",
                   help="COLMAP's exhaustive CPU matcher, or our mutual-NN matches [colmap]")
    s.add_argument("--dataset", metavar="NAME", help="data set name in tables [the folder's name]")
    s.add_argument("--out", metavar="DIR", help="write sfm.json and sfm.md here (work files in OUT/work)")
    s.add_argument("--work", metavar="DIR", help="database and models here [OUT/work or a temp folder]")
    s.add_argument("--no-dense", action="store_true", help="do not try MVS (it needs a CUDA build anyway)")
    s.add_argument("--threads", type=int, default=-1, help="COLMAP threads [-1: all]")
    s.add_argument("--seed", type=int, default=0, help="COLMAP random seed [0]")
    s.add_argument("--time-limit", type=float, default=-1, help="mapper time limit in seconds [-1: none]")
    s.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    s.add_argument("--quiet", action="store_true", help="no progress on stderr")
    s.set_defaults(func=run_sfm_cmd)
