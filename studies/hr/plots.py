"""Figures of the hr study: ``python plots.py STAGE_FILE OUT.png [--half dev] [--screen]``.

One panel per benchmark of the objective, one bar per row (baselines grey,
variants blue, the chosen ``hr`` row orange), rows in mean-rank order.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from run_study import load  # noqa: E402
from tables import COLS, read_stage, table  # noqa: E402
from variants import BASELINES  # noqa: E402


def figure(rows: list[str], half: str, out: str, title: str = "") -> Path:
    _, ranks = table(rows, half)
    order = sorted(ranks, key=lambda r: (ranks[r], r))
    res = {r: load(half, r) for r in order}
    fig, axes = plt.subplots(1, len(COLS), figsize=(3.0 * len(COLS), 0.28 * len(order) + 1.6), sharey=True)
    for ax, (b, k, name) in zip(axes, COLS):
        vals = [res[r].get(b, {}).get(k, math.nan) for r in order]
        vals = [math.nan if v is None else v for v in vals]
        colours = ["#999999" if r in BASELINES else ("#e07b00" if r.startswith("hr") else "#3b75af")
                   for r in order]
        ax.barh(range(len(order)), vals, color=colours)
        ax.set_title(name + (" (lower better)" if k == "mean_error" else ""), fontsize=9)
        ax.tick_params(labelsize=7)
        ax.grid(axis="x", alpha=0.3)
    axes[0].set_yticks(range(len(order)))
    axes[0].set_yticklabels([f"{r}  ({ranks[r]:.2f})" for r in order], fontsize=7)
    axes[0].invert_yaxis()
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    p = Path(out)
    p.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(p, dpi=110)
    plt.close(fig)
    return p


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("stage")
    ap.add_argument("out")
    ap.add_argument("--half", default="dev")
    ap.add_argument("--title", default="")
    a = ap.parse_args(argv)
    print(figure(read_stage(a.stage), a.half, a.out, a.title))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
