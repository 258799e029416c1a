"""Tables of the hr2 study from ``studies/hr2/results/`` (docs/hr2.md, section 4).

    python studies/hr2/tables.py --half dev

One table per benchmark (every cached row, with its time and command) and the screening ranking
(mean rank over B1-rot, B1-pos, B2-1, B2-3, B2-H) over the rows that have both benchmarks.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"
SCENES = ("fountain-P11", "Herz-Jesus-P8")


def load(half: str, bench: str) -> dict[str, dict]:
    out = {}
    for p in sorted((RESULTS / half / bench).glob("*.json")):
        d = json.loads(p.read_text())
        out[d["row"]] = d
    return out


def _sp(x: dict | None, nd: int) -> str:
    if not x:
        return "–"
    return f"{x['median']:.{nd}f} ({x['min']:.{nd}f}–{x['max']:.{nd}f})"


def sfm_table(rows: dict[str, dict]) -> str:
    lines = ["| row | scene | reg. (all seeds) | features/img | points | reproj. (px) | rot. err. (deg) "
             "| pos. err. (mm) | time (s) | command |", "|---|---|---|---|---|---|---|---|---|---|"]
    for row, d in rows.items():
        for s in SCENES:
            r = d["result"][s]
            sp = r["spread"]
            pos = sp.get("position_median")
            pos_mm = None if not pos else {k: (v * 1000 if k != "values" else v) for k, v in pos.items()}
            lines.append(
                f"| `{row}` | {s} | {'yes' if r['all_registered'] else 'NO'} "
                f"({r['registered']}/{r['images']}) | "
                f"{r['features']:.0f} | {_sp(sp['points'], 0)} | {_sp(sp['reproj_error'], 2)} | "
                f"{_sp(sp['rotation_deg_median'], 3)} | {_sp(pos_mm, 1)} | {r['seconds']:.0f} | "
                + (f"`{d['command']}` |" if s == SCENES[0] else "|"))
    return "\n".join(lines) + "\n"


def matching_table(rows: dict[str, dict]) -> str:
    lines = ["| row | graf MMA@1 / @3 / AUC@3 | v_wormhole | HOMOGR | mean MMA@1 | mean MMA@3 | mean AUC@3 "
             "| time (s) | command |", "|---|---|---|---|---|---|---|---|---|"]
    for row, d in sorted(rows.items(), key=lambda kv: -kv[1]["result"]["mma1"]):
        r = d["result"]
        cells = [f"{r[n]['mma1']:.3f} / {r[n]['mma3']:.3f} / {r[n]['auc3']:.2f}"
                 for n in ("oxford", "hpatches", "homogr")]
        lines.append(f"| `{row}` | " + " | ".join(cells) + f" | {r['mma1']:.3f} | {r['mma3']:.3f} | "
                     f"{r['auc3']:.3f} | {d['seconds']:.0f} | `{d['command']}` |")
    return "\n".join(lines) + "\n"


def ranking(sfm: dict, mm: dict) -> str:
    from scipy.stats import rankdata

    rows = [r for r in mm if r in sfm]
    if not rows:
        return ""
    cols = {
        "B1-rot": ([sfm[r]["result"].get("rotation_deg_median") for r in rows], False),
        "B1-pos": ([sfm[r]["result"].get("position_median") for r in rows], False),
        "B2-1": ([mm[r]["result"]["mma1"] for r in rows], True),
        "B2-3": ([mm[r]["result"]["mma3"] for r in rows], True),
        "B2-H": ([mm[r]["result"]["auc3"] for r in rows], True),
    }
    ranks = np.zeros(len(rows))
    for vals, higher in cols.values():
        v = np.array([math.nan if x is None else x for x in vals], dtype=np.float64)
        v = np.where(np.isfinite(v), -v if higher else v, np.inf)
        ranks += rankdata(v, method="average")
    ranks /= len(cols)
    lines = ["| row | mean rank | B1 rot. (deg) | B1 pos. (mm) | B2 MMA@1 | B2 MMA@3 | B2 AUC@3 |",
             "|---|---|---|---|---|---|---|"]
    for i in np.argsort(ranks, kind="stable"):
        r = rows[i]

        def f(x, nd, scale=1.0):
            return "fail" if x is None else f"{x * scale:.{nd}f}"

        lines.append(f"| `{r}` | {ranks[i]:.2f} | {f(cols['B1-rot'][0][i], 3)} | "
                     f"{f(cols['B1-pos'][0][i], 2, 1000)} | {cols['B2-1'][0][i]:.3f} | "
                     f"{cols['B2-3'][0][i]:.3f} | "
                     f"{cols['B2-H'][0][i]:.3f} |")
    return "\n".join(lines) + "\n"


def finalists_table(half: str) -> str:
    """B3 (top-500 repeatability per family), B4 (GT F1) and the constraints C1, C2 of the finalists."""
    rows = load(half, "final")
    if not rows:
        return ""
    fams = ("rotation", "scale", "anisotropic", "shear", "jpeg", "noise", "blur")
    lines = ["| row | B3 overall | " + " | ".join(fams) + " | B4 GT F1 | C1 chess err. (px, <= 0.10) "
             "| C2 adjacent (>= 0.881) | time (s) | command |",
             "|---|---|" + "---|" * len(fams) + "---|---|---|---|---|"]
    for row, d in rows.items():
        r = d["result"]
        c1, c2 = r["C1"]["mean_error"], r["C2"]["mean_rate"]
        lines.append(f"| `{row}` | {r['B3']['overall']:.3f} | " + " | ".join(f"{r['B3'][f]:.3f}" for f in fams)
                     + f" | {r['B4']['f1']:.3f} | {c1:.3f} {'ok' if c1 <= 0.10 else 'FAILS'} | "
                     f"{c2:.3f} {'ok' if c2 >= 0.881 else 'FAILS'} | {d['seconds']:.0f} | `{d['command']}` |")
    return "\n".join(lines) + "\n"


def residuals_table(half: str) -> str:
    """Bias and spread of the residuals of the matches within 3 px (viewpoint change, 2,000 points)."""
    rows = load(half, "residuals")
    if not rows:
        return ""
    lines = ["| row | graf: bias / sd / median (n) | v_wormhole | HOMOGR | time (s) | command |",
             "|---|---|---|---|---|---|"]
    for row, d in rows.items():
        r = d["result"]
        cells = [f"{r[n]['bias']:.3f} / {r[n]['sd']:.3f} / {r[n]['median']:.3f} ({r[n]['n']})"
                 for n in ("oxford", "hpatches", "homogr")]
        lines.append(f"| `{row}` | " + " | ".join(cells) + f" | {d['seconds']:.0f} | `{d['command']}` |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--half", default="dev")
    a = ap.parse_args(argv)
    sfm, mm = load(a.half, "sfm"), load(a.half, "matching")
    print(f"### Screening ranking ({a.half})\n\n" + ranking(sfm, mm))
    print(f"### B1: SfM, {a.half} half, seeds 0, 1, 2 (median (min–max))\n\n" + sfm_table(sfm))
    print(f"### B2: matching at 2,000 points, {a.half} pairs\n\n" + matching_table(mm))
    res = residuals_table(a.half)
    if res:
        print(f"### Refinement under viewpoint change: residuals of the matches within 3 px ({a.half})\n\n"
              + res)
    fin = finalists_table(a.half)
    if fin:
        print(f"### Finalists: B3, B4 and the constraints ({a.half})\n\n" + fin)
    return 0


if __name__ == "__main__":
    sys.exit(main())
