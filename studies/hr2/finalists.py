"""B3, B4 and the constraints for the hr2 study's finalists (docs/hr2.md, section 1).

    python studies/hr2/finalists.py --half dev --rows sogdd-hr 'hr2:...'

B3: top-500 repeatability per family (quick grid, plus blur) and B4: joint-threshold GT F1, both from
``studies/hr/bench.py`` on the half's images; C1: dense checkerboards, full scene grid, cells 5, 6, 8, 12
(mean error <= 0.10 px); C2: adjacent corners, full grid, default thresholds (mean resolved rate
>= 0.881). One JSON per row under ``results/<half>/final/``.
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.append(str(HERE.parent / "hr"))  # for the first study's _compat
import bench as hr2bench  # noqa: E402


def _hr_bench():
    """studies/hr/bench.py, loaded by path (both studies name their module ``bench``)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("hr_bench", HERE.parent / "hr" / "bench.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


hrbench = _hr_bench()

from sogdd.evaluation.chessboard import evaluate as chess_evaluate  # noqa: E402
from sogdd.evaluation.resolution import evaluate_resolution  # noqa: E402
from sogdd.evaluation.specs import build_detector, parse_spec  # noqa: E402

CELLS = (5, 6, 8, 12)


def finalist(row: str, half: str) -> dict:
    spec = parse_spec(row)
    det = build_detector(spec)
    seed = 0 if half == "dev" else 1
    out: dict = {}
    t = time.perf_counter()
    out["B3"] = hrbench.bench_repeat(det, half)
    out["B3"]["seconds"] = round(time.perf_counter() - t, 1)
    t = time.perf_counter()
    out["B4"] = hrbench.bench_gt(det, half)
    out["B4"]["seconds"] = round(time.perf_counter() - t, 1)
    t = time.perf_counter()
    ch = chess_evaluate(det, cells=CELLS, quick=False, seed=seed)
    errs = [ch[f"{c}"]["mean_error"] if ch[f"{c}"]["recall"] >= 0.5 else 1.0 for c in CELLS]
    out["C1"] = {"mean_error": float(np.mean(errs)), "per_cell": {f"{c}": ch[f"{c}"] for c in CELLS},
                 "seconds": round(time.perf_counter() - t, 1)}
    t = time.perf_counter()
    rr = evaluate_resolution([spec], quick=False, seed=seed, mode="default", progress=False)
    out["C2"] = {"mean_rate": float(rr.mean_rate(spec.label)), "seconds": round(time.perf_counter() - t, 1)}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--half", choices=("dev", "conf"), default="dev")
    ap.add_argument("--rows", nargs="+", required=True)
    a = ap.parse_args(argv)
    for row in a.rows:
        p = hr2bench.Path(HERE / "results" / a.half / "final" / f"{hr2bench._safe(row)}.json")
        if p.is_file():
            continue
        t0 = time.perf_counter()
        res = finalist(row, a.half)
        p.parent.mkdir(parents=True, exist_ok=True)
        cmd = f"python studies/hr2/finalists.py --half {a.half} --rows {shlex.quote(row)}"
        p.write_text(json.dumps({"row": row, "half": a.half, "seconds": round(time.perf_counter() - t0, 1),
                                 "command": cmd, "result": res}, indent=1, default=float))
        print(row, round(time.perf_counter() - t0, 1), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
