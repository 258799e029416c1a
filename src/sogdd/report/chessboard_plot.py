"""The benchmark's figure: mean error and recall against cell size, one line per detector."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ..evaluation.chessboard.protocol import ChessboardReport

__all__ = ["chessboard_figure"]


def chessboard_figure(rep: ChessboardReport, path: str | os.PathLike) -> Path:
    """Write a two-panel PNG: mean error of located corners (log scale) and recall at 1 px."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax_e, ax_r) = plt.subplots(1, 2, figsize=(11, 4.2))
    colours = plt.get_cmap("tab20").colors  # distinct up to 20 rows (the default cycle has 10)
    markers = "os^vDPX*<>"
    for k, lab in enumerate(rep.labels):
        style = {"color": colours[(2 * k) % 20 + (k // 10) % 2], "marker": markers[k % len(markers)]}
        pc = rep.per_cell(lab)
        cs = [c for c in rep.cells if f"{c:g}" in pc]
        err = [pc[f"{c:g}"]["mean_error"] for c in cs]
        ce = [c for c, e in zip(cs, err) if e is not None]
        ax_e.plot(ce, [e for e in err if e is not None], label=lab, **style)
        ax_r.plot(cs, [pc[f"{c:g}"]["recall"] for c in cs], label=lab, **style)
    ax_e.set(xlabel="cell size (px)", ylabel="mean error of located corners (px)", yscale="log",
             title="error (corners located within cell/2)")
    ax_r.set(xlabel="cell size (px)", ylabel="recall (detection within 1 px)", ylim=(-0.02, 1.02),
             title="recall")
    for ax in (ax_e, ax_r):
        ax.set_xticks(rep.cells)
        ax.set_xticklabels([f"{c:g}" for c in rep.cells])
        ax.grid(alpha=0.3)
    ax_r.legend(fontsize=7, loc="lower right")
    g = "quick grid" if rep.quick else "full grid"
    fig.suptitle(f"Dense checkerboards ({g}): rendered, anti-aliased, PSF and noise")
    fig.tight_layout()
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(p, dpi=120)
    plt.close(fig)
    return p
