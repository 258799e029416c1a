"""Run hr2 study rows and cache one JSON per (half, benchmark, row) under ``studies/hr2/results/``.

    python studies/hr2/run.py --half dev --bench matching sfm --rows sogdd-hr sift 'hr2:budget=4000:select=anms'

Each file holds the benchmark's numbers, its wall time and the command that re-makes it;
a cached row is skipped (``--force`` re-runs it).
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import bench  # noqa: E402

RESULTS = HERE / "results"


def path_of(half: str, b: str, row: str) -> Path:
    return RESULTS / half / b / f"{bench._safe(row)}.json"


def run_one(half: str, b: str, row: str, force: bool = False) -> tuple[str, str, float]:
    if not force and path_of(half, b, row).is_file():  # done meanwhile by another run
        return row, b, 0.0
    t0 = time.perf_counter()
    res = bench.BENCHES[b](row, half)
    sec = time.perf_counter() - t0
    cmd = f"python studies/hr2/run.py --half {half} --bench {b} --rows {shlex.quote(row)}"
    p = path_of(half, b, row)
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(json.dumps({"row": row, "half": half, "bench": b, "seconds": round(sec, 1), "command": cmd,
                             "finished": time.strftime("%H:%M:%S", time.gmtime()), "result": res},
                            indent=1, default=float))
    return row, b, sec


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--half", choices=("dev", "conf", "full"), default="dev")
    ap.add_argument("--bench", nargs="+", choices=sorted(bench.BENCHES), default=["matching", "sfm"])
    ap.add_argument("--rows", nargs="+", required=True)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--force", action="store_true")
    a = ap.parse_args(argv)
    todo = [(a.half, b, r) for r in a.rows for b in a.bench if a.force or not path_of(a.half, b, r).is_file()]
    if a.jobs <= 1:
        for t in todo:
            print(*run_one(*t, force=a.force), flush=True)
    else:
        with ProcessPoolExecutor(a.jobs) as ex:
            for r in ex.map(run_one, *zip(*todo)):
                print(*r, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
