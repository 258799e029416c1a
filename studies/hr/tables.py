"""Tables and plots of the hr study from the cached results: ``python tables.py STAGE_FILE [--half dev]``.

A stage file lists rows, one per line (``#`` comments). The table ranks every
row of the stage together with the baselines (docs/hr.md, section 1) and
prints Markdown with each row's command and wall time.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import bench  # noqa: E402
from run_study import load  # noqa: E402
from variants import BASELINES  # noqa: E402

COLS = (("gt", "f1", "GT F1"), ("repeat", "overall", "rep. top-500"), ("repeat", "blur", "rep. blur"),
        ("resolution", "mean_rate", "resolved d<=6"), ("chessboard", "mean_error", "chess err 4-8 px"),
        ("mma", "mean", "MMA@3"))


def read_stage(path: str) -> list[str]:
    rows = []
    for line in Path(path).read_text().splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            rows.append(line)
    return rows


def table(rows: list[str], half: str, with_baselines: bool = True) -> tuple[str, dict]:
    allrows = list(dict.fromkeys((list(BASELINES) if with_baselines else []) + rows))
    res = {r: load(half, r) for r in allrows}
    res = {r: v for r, v in res.items() if v}
    ranks = bench.mean_ranks(res)
    head = "| row | mean rank | " + " | ".join(c[2] for c in COLS) + " | time (s) | command |"
    out = [head, "|---|---|" + "---|" * len(COLS) + "---|---|"]
    for r in sorted(res, key=lambda x: (ranks[x], x)):
        v = res[r]
        cells = []
        for b, k, _ in COLS:
            x = v.get(b, {}).get(k, math.nan)
            cells.append("-" if x is None or not math.isfinite(x) else f"{x:.3f}")
        secs = sum(v[b].get("seconds", 0) for b in v)
        env = "HR_SCREEN=1 " if bench.SCREEN else ""
        cmd = f"`{env}python studies/hr/run_study.py --half {half} --rows '{r}'`"
        out.append(f"| {r} | {ranks[r]:.2f} | " + " | ".join(cells) + f" | {secs:.0f} | {cmd} |")
    return "\n".join(out) + "\n", ranks


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("stage")
    ap.add_argument("--half", default="dev")
    ap.add_argument("--no-baselines", action="store_true")
    a = ap.parse_args(argv)
    t, _ = table(read_stage(a.stage), a.half, not a.no_baselines)
    print(t)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
