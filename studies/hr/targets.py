"""Issue-13 target checks that the objective does not cover: ``python targets.py chess|speed``.

``chess``: the dense-checkerboard target (every corner within 0.5 px, mean error <= 0.10 px at cells
5-12 with PSF 0.7 and noise 0 or 5; 30x better than GFTT + cornerSubPix at 5-6 px), full scene grid,
both seeds, with the package's ``sogdd-hr`` (the core implementation, not the prototype).
``speed``: ``detect_corners(preset="hr")`` against SIFT's detect on the same photos, interleaved,
median of repeats (the same process, so a loaded machine slows both).
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def chess() -> dict:
    from sogdd.evaluation.chessboard import run_benchmark

    out = {}
    for half, seed in (("dev", 0), ("conf", 1)):
        t0 = time.perf_counter()
        rep = run_benchmark(["sogdd-hr", "gftt+subpix", "sogdd"], cells=[5, 6, 8, 12], seed=seed)
        res = {}
        for lab in rep.labels:
            res[lab] = {f"noise={nz:g}": rep.per_cell(lab, psf=0.7, noise=nz) for nz in (0.0, 5.0)}
            res[lab]["all"] = rep.per_cell(lab)
        out[half] = {"rows": res, "seconds": round(time.perf_counter() - t0, 1)}
    return out


def speed(repeats: int = 7) -> dict:
    import cv2

    import sogdd

    sift = cv2.SIFT_create()
    rows = {}
    for name in ("Lena.bmp", "house003.bmp", "flower001.bmp"):
        img = cv2.imread(str(Path("/work/shared/data/repeatability") / name), cv2.IMREAD_GRAYSCALE)
        sogdd.detect_corners(img, preset="hr")
        sift.detect(img)
        th, ts = [], []
        for _ in range(repeats):
            t0 = time.perf_counter()
            sogdd.detect_corners(img, preset="hr")
            t1 = time.perf_counter()
            sift.detect(img)
            t2 = time.perf_counter()
            th.append(t1 - t0)
            ts.append(t2 - t1)
        rows[name] = {"hr_ms": 1e3 * float(np.median(th)), "sift_ms": 1e3 * float(np.median(ts)),
                      "ratio": float(np.median(th) / np.median(ts))}
    return rows


if __name__ == "__main__":
    what = sys.argv[1]
    res = {"chess": chess, "speed": speed}[what]()
    p = HERE / "results" / f"targets_{what}.json"
    p.parent.mkdir(exist_ok=True)
    p.write_text(json.dumps(res, indent=1, default=float))
    print(json.dumps(res, default=float)[:3000])
