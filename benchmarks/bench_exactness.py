"""Agreement of the fast measure with the direct implementation of eqs. 22-25.

For each image and preset: the largest relative difference of Upsilon over the
pixels with Upsilon >= 1e6, over those of them whose SODDC matrix has a
condition number <= 1e8, and over the pixels above the paper's T_h = 1e9.

Run: ``python benchmarks/bench_exactness.py [--data ../shared/data] [--readme docs/explanations/exactness.md]``
(``--readme`` writes the table into that page's ``exactness`` block).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import cv2
import numpy as np

import sogdd
from sogdd.measure.oracle import reference_lambda, reference_measure
from sogdd.measure.soddc import soddc_measure
from sogdd.report.readme_sync import sync_readme
from sogdd.report.tables import markdown_table
from sogdd.synthetic import pattern_image


def _max_rel(fast: np.ndarray, ref: np.ndarray, mask: np.ndarray) -> str:
    if not mask.any():
        return "      -"
    return f"{np.max(np.abs(fast[mask] - ref[mask]) / np.abs(ref[mask])):.1e}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=os.environ.get("SOGDD_DATA", "../shared/data"))
    ap.add_argument("--readme", metavar="PATH",
                    help="write the table into this page's 'exactness' block (docs/explanations/exactness.md)")
    args = ap.parse_args()
    images = {"rendered pattern 240×320": pattern_image((240, 320), seed=1)[0]}
    geo = sorted((Path(args.data) / "corners_gt" / "geometric").glob("image.*"))
    if geo:
        images["Geometric, 200×300 crop"] = cv2.imread(str(geo[0]), cv2.IMREAD_GRAYSCALE)[:200, :300]
    print(f"{'image':26s} {'preset':8s} {'>=1e6':>8s} {'>=1e6, cond<=1e8':>17s} {'>=1e9':>8s}")
    rows = []
    for name, img in images.items():
        grey = img.astype(np.float64)
        for preset in ("paper", "authors"):
            spec = sogdd.resolve_params(preset).measure_spec()
            ref = reference_measure(grey, spec)
            fast = soddc_measure(grey, spec)
            lam = reference_lambda(grey, spec)
            cond = np.linalg.cond(lam.reshape(-1, *lam.shape[-2:])).reshape(ref.shape)
            big = np.abs(ref) >= 1e6
            row = [name, preset] + [_max_rel(fast, ref, m).strip()
                                    for m in (big, big & (cond <= 1e8), ref >= 1e9)]
            rows.append(row)
            print(f"{row[0]:26s} {row[1]:8s} {row[2]:>8s} {row[3]:>17s} {row[4]:>8s}")
    if args.readme:
        header = ["image", "preset", "all pixels with Υ ≥ 1e6", "those with cond(Λ) ≤ 1e8", "Υ ≥ T_h = 1e9"]
        table = markdown_table(header, rows, "ll" + "r" * 3)
        print("blocks changed:", sync_readme(args.readme, {"exactness": table}))


if __name__ == "__main__":
    main()
