"""Run hr-study rows: ``python run_study.py --half dev --rows NAME,... [--benches gt,repeat] [--jobs 2]``.

A row is a baseline (registry name) or a prototype variant named in
:data:`variants.ROWS`. Each (half, row) result is cached as JSON under
``results/<half>/<row>.json`` with every benchmark's wall time, and merged when
more benchmarks are run later; ``--force`` recomputes.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import bench  # noqa: E402
from variants import BASELINES, detector_for  # noqa: E402

RESULTS = HERE / "results"


def _path(half: str, row: str) -> Path:
    return RESULTS / (half + ("_screen" if bench.SCREEN else "")) / f"{row}.json"


def load(half: str, row: str) -> dict:
    p = _path(half, row)
    return json.loads(p.read_text()) if p.is_file() else {}


def _one(row: str, half: str, benches: list[str]) -> tuple[str, dict]:
    det = detector_for(row)
    return row, bench.run(det, half, benches)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--half", default="dev", choices=bench.HALVES)
    ap.add_argument("--rows", required=True, help="comma-separated; 'baselines' for all baselines")
    ap.add_argument("--benches", default=",".join(bench.BENCHES))
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--force", action="store_true")
    a = ap.parse_args(argv)
    rows = []
    for r in a.rows.split(","):
        rows += list(BASELINES) if r == "baselines" else [r]
    for r in rows:
        detector_for(r)  # fails early on an unknown row
    benches = a.benches.split(",")
    todo = []
    for r in rows:
        have = load(a.half, r)
        need = [b for b in benches if a.force or b not in have]
        if need:
            todo.append((r, need))
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=max(1, a.jobs)) as ex:
        futs = [ex.submit(_one, r, a.half, need) for r, need in todo]
        for f in as_completed(futs):
            row, res = f.result()
            cur = load(a.half, row)
            cur.update(res)
            _path(a.half, row).parent.mkdir(parents=True, exist_ok=True)
            _path(a.half, row).write_text(json.dumps(cur, indent=1, default=float))
            print(row, {b: {k: v for k, v in res[b].items() if not isinstance(v, dict)} for b in res},
                  flush=True)
    print(f"done in {time.perf_counter() - t0:.0f} s", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
