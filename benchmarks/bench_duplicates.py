"""Coincident corners: how many of the detector's points lie on top of another, per preset.

Sub-pixel refinement can bring two local maxima of Upsilon onto one point (two
peaks around one vertex converge to one fixed point of the gradient refinement).
For each preset, the script detects on every image of a folder (by default the
12 repeatability photos of the shared data) and counts, over all images,

* the corners, and the distinct positions among them (points within ``--tol`` px
  of each other joined into one cluster, transitively);
* the pairs of corners closer than ``--tol`` px (0.01 by default) and closer than
  :data:`sogdd.select.refine.COINCIDENT` (the merge radius of the detector);
* with ``--max-corners N`` (thresholds off, the N strongest), the images that
  got fewer than N distinct corners.

Run it in two checkouts to compare versions (the ``sogdd`` imported is the one
the interpreter finds; the output names its path)::

    python benchmarks/bench_duplicates.py --data ../shared/data [--max-corners 500] [--json]
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

import sogdd

PRESETS = ("paper", "authors", "hr")
#: the radius the detector merges within, from the checkout that runs (0.1 px where it is not defined)
try:
    from sogdd.select.refine import COINCIDENT as MERGE
except ImportError:  # a version before the merge of coincident points in every preset
    MERGE = 0.1


def coincident(xy: np.ndarray, tol: float) -> tuple[int, int]:
    """(pairs closer than ``tol``, distinct positions): clusters of points linked by such pairs.

    Examples
    --------
    >>> coincident(np.array([[0.0, 0.0], [0.0, 0.001], [5.0, 5.0]]), 0.01)
    (1, 2)
    """
    if len(xy) < 2:
        return 0, len(xy)
    pairs = cKDTree(xy).query_pairs(tol, output_type="ndarray")
    if len(pairs) == 0:
        return 0, len(xy)
    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(xy), len(xy)))
    return len(pairs), int(connected_components(g, directed=False)[0])


def run(folder: Path, presets: tuple[str, ...], tol: float, max_corners: int | None) -> dict:
    """The counts per preset over every image of ``folder``, and per image."""
    files = sorted(p for p in folder.iterdir() if p.suffix.lower() in {".bmp", ".png", ".jpg", ".ppm", ".pgm"})
    out: dict = {"sogdd": str(Path(sogdd.__file__).resolve().parent), "tol": tol, "merge": MERGE,
                 "images": len(files), "presets": {}}
    for preset in presets:
        row = {"corners": 0, "distinct": 0, "pairs_tol": 0, "pairs_merge": 0, "per_image": {}}
        short = 0
        for f in files:
            img = sogdd.read_image(f)
            c = sogdd.detect_corners(img, preset=preset)
            pairs, distinct = coincident(c.xy, tol)
            merge_pairs = coincident(c.xy, MERGE)[0]
            row["corners"] += len(c)
            row["distinct"] += distinct
            row["pairs_tol"] += pairs
            row["pairs_merge"] += merge_pairs
            row["per_image"][f.name] = {"corners": len(c), "distinct": distinct, "pairs_tol": pairs}
            if max_corners is not None:
                # thresholds off: the N strongest, whatever they are
                off = dict(threshold=None, threshold_rel=None, quantile=None)
                top = sogdd.detect_corners(img, preset=preset, max_corners=max_corners, **off)
                short += coincident(top.xy, tol)[1] < max_corners
        if max_corners is not None:
            row["short_of_max_corners"] = short
        out["presets"][preset] = row
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=os.environ.get("SOGDD_DATA", "../shared/data"),
                    help="the shared data folder")
    ap.add_argument("--images", help="a folder of images [default: DATA/repeatability]")
    ap.add_argument("--presets", default=",".join(PRESETS))
    ap.add_argument("--tol", type=float, default=0.01, help="px: closer pairs count as coincident")
    ap.add_argument("--max-corners", type=int, help="also check that the N strongest are N distinct points")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args()
    folder = Path(args.images) if args.images else Path(args.data) / "repeatability"
    res = run(folder, tuple(args.presets.split(",")), args.tol, args.max_corners)
    if args.json:
        print(json.dumps(res, indent=1))
        return
    print(f"sogdd at {res['sogdd']}; {res['images']} images in {folder}; merge radius {res['merge']} px")
    pairs = f"{'pairs<' + str(args.tol):>11} {'pairs<' + str(MERGE):>10}"
    head = f"{'preset':8} {'corners':>8} {'distinct':>8} {pairs}"
    print(head + ("  short of N" if args.max_corners else ""))
    for preset, r in res["presets"].items():
        extra = f"  {r['short_of_max_corners']:>10}" if args.max_corners else ""
        counts = f"{r['corners']:8d} {r['distinct']:8d} {r['pairs_tol']:11d} {r['pairs_merge']:10d}"
        print(f"{preset:8} {counts}{extra}")


if __name__ == "__main__":
    main()
