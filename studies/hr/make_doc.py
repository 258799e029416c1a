"""Regenerate the result sections of docs/hr.md and its figures from the cached results.

``python studies/hr/make_doc.py``: replaces the text between
``<!-- generated:begin -->`` and ``<!-- generated:end -->`` in docs/hr.md with the
stage tables (screening protocol), the final tables (full protocol, both halves)
and the target checks, and writes docs/figures/hr/*.png.
"""

from __future__ import annotations

import json
import math
import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(HERE))

DOC = ROOT / "docs" / "hr.md"
FIG = ROOT / "docs" / "figures" / "hr"
BEGIN, END = "<!-- generated:begin -->", "<!-- generated:end -->"


def _stage(name: str, file: str, half: str, screen: bool, title: str) -> str:
    os.environ["HR_SCREEN"] = "1" if screen else ""
    import importlib

    import bench

    importlib.reload(bench)
    import plots
    import run_study
    import tables

    for m in (run_study, tables, plots):
        importlib.reload(m)
    rows = tables.read_stage(str(HERE / file))
    t, _ = tables.table(rows, half)
    png = plots.figure(rows, half, str(FIG / f"{name}.png"), title)
    return f"### {title}\n\n![{name}](figures/hr/{png.name})\n\n{t}\n"


def _fmt(v, nd=3):
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.{nd}f}"


def _targets() -> str:
    out = []
    p = HERE / "results" / "targets_chess.json"
    if p.is_file():
        js = json.loads(p.read_text())
        out.append("### Dense checkerboards, full scene grid, PSF 0.7 (core `sogdd-hr`)\n")
        out.append("mean error px / p95 px / recall (1 px) / false per corner, per cell size\n")
        out.append("| half | detector | noise | 5 px | 6 px | 8 px | 12 px |\n|---|---|---|---|---|---|---|")
        for half, block in js.items():
            for lab, per in block["rows"].items():
                for nz in ("noise=0", "noise=5"):
                    cells = per.get(nz, {})
                    vals = []
                    for c in ("5", "6", "8", "12"):
                        r = cells.get(c)
                        vals.append("-" if r is None else f"{_fmt(r['mean_error'])} / {_fmt(r['p95_error'])} / "
                                    f"{_fmt(r['recall'], 2)} / {_fmt(r['false'], 2)}")
                    out.append(f"| {half} | {lab} | {nz[6:]} | " + " | ".join(vals) + " |")
        out.append("")
    p = HERE / "results" / "targets_speed.json"
    if p.is_file():
        js = json.loads(p.read_text())
        out.append("### Speed: `detect_corners(preset=\"hr\")` against SIFT's detect, same process, "
                   "interleaved, median of 7\n")
        out.append("| photo | hr (ms) | SIFT (ms) | ratio (target <= 0.3) |\n|---|---|---|---|")
        for k, v in js.items():
            out.append(f"| {k} | {v['hr_ms']:.1f} | {v['sift_ms']:.1f} | {v['ratio']:.2f} |")
        out.append("")
    return "\n".join(out)


def main() -> int:
    FIG.mkdir(parents=True, exist_ok=True)
    parts = [
        _stage("stage_a", "stage_a.txt", "dev", True,
               "Stage A: one factor at a time from the base (dev, screening)"),
        _stage("stage_b", "stage_b.txt", "dev", True, "Stage B: combinations (dev, screening)"),
        _stage("stage_c", "stage_c.txt", "dev", True, "Stage C: ablation around the first pick, sigma^2 = 1.2 "
               "(dev, screening)"),
        _stage("stage_d", "stage_d.txt", "dev", True, "Stage D: ablation, one choice at a time from hr (dev, "
               "screening)"),
        _stage("final_dev", "final.txt", "dev", False, "Final: development half, full protocol"),
        _stage("final_conf", "final.txt", "conf", False, "Final: confirmation half, full protocol"),
        _targets(),
    ]
    text = DOC.read_text()
    i, j = text.index(BEGIN) + len(BEGIN), text.index(END)
    DOC.write_text(text[:i] + "\n\n" + "\n".join(parts) + "\n" + text[j:])
    print(f"wrote {DOC} and {FIG}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
