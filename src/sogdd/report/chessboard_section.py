"""The results page's dense-checkerboard section (``sogdd eval chessboard``'s benchmark)."""

from __future__ import annotations

import time
from pathlib import Path

from ..evaluation.chessboard import CELLS, DEFAULT_ROWS, run_benchmark
from ..evaluation.chessboard.calibration import calibration_root, evaluate_calibration
from ..evaluation.chessboard.scenes import FULL_GRID, QUICK_GRID
from .chessboard_plot import chessboard_figure
from .tables import markdown_table, rank_of

__all__ = ["chessboard_rows", "chessboard_stage", "real_markdown"]


def chessboard_rows(extra: list[str]) -> list[str]:
    """The benchmark's default rows with ``extra`` registry names after the SOGDD presets."""
    rows = list(DEFAULT_ROWS)
    at = max(i for i, r in enumerate(rows) if r.startswith("sogdd")) + 1
    return rows[:at] + [e for e in extra if e not in rows] + rows[at:]


def real_markdown(real: dict) -> str:
    """The calibration photos' check: recall within 1 px, mean / p95 error, false per corner."""
    out = []
    for ds, rows in real["datasets"].items():
        off = real["offset"].get(ds)
        out.append(f"\n**{ds}** (label offset removed: dx = {off[0]:+.2f}, dy = {off[1]:+.2f} px)\n")
        table = [[f"`{lab}`", r["all"]["recall"], r["all"]["mean_error"], r["all"]["p95_error"],
                  r["all"]["false"]] for lab, r in rows.items()]
        out.append(markdown_table(["detector", "recall (1 px)", "mean error (px)", "p95 error (px)",
                                   "false / corner"], table))
    return "\n".join(out) + "\n"


def chessboard_stage(page, data: Path, *, extra: list[str] | None = None, cells=CELLS,
                     quick: bool = False) -> None:
    """Section 4: rendered dense checkerboards, and the real calibration photos under ``data``."""
    rows = chessboard_rows(extra or [])
    t0 = time.perf_counter()
    rep = run_benchmark(rows, cells=cells, quick=quick, progress=page.progress)
    root = calibration_root(data / "calibration") if (data / "calibration").is_dir() else None
    real = evaluate_calibration(rows, root) if root is not None else None
    page.seconds["chessboard"] = time.perf_counter() - t0
    chessboard_figure(rep, page.figs / "chessboard.png")
    g = QUICK_GRID if quick else FULL_GRID
    n_scenes = sum(1 for r in rep.records if r["detector"] == rep.labels[0])
    recall = {lab: _mean([v["recall"] for v in rep.per_cell(lab).values()]) for lab in rep.labels}
    if "sogdd" in recall:
        r, n = rank_of(recall, "sogdd")
        page.ranks.append(f"Dense checkerboards ({'quick' if quick else 'full'} grid, mean recall at 1 px over "
                          f"cells {_list(rep.cells)} px): sogdd ranks **{r} of {n}**")
    small = [c for c in rep.cells if c <= 6] or rep.cells
    sog = rep.per_cell("sogdd") if "sogdd" in rep.labels else {}
    page.md += [
        "\n## 4. Dense checkerboards (beyond the paper)\n",
        f"Run by `sogdd report` ({'quick' if quick else 'full'} grid, {page.seconds['chessboard']:.0f} s; "
        f"the same as `sogdd eval chessboard{' --quick' if quick else ''} --detectors {','.join(rows)}`). "
        f"Rendered checkerboards with exact sub-pixel inner corners, cells {_list(rep.cells)} px, "
        f"{g.phases} random sub-pixel phase(s) per setting, rotations {_list(g.angles)}°, "
        f"Gaussian PSF σ {_list(g.psfs)} px, noise σ {_list(g.noises)} grey levels: {n_scenes} boards. "
        "Every detector at its defaults. Per cell size (`sogdd.evaluation.chessboard.metrics`): "
        "*recall* = inner corners with a detection within 1 px; *false* = detections inside the inner "
        "corners' area (grown by half a cell) "
        "farther than 1 px from every inner corner, per corner; *duplicates* = further detections within "
        "1 px of a corner already hit, per corner; the error is the mean distance of the corners located "
        "within half a cell (p95 in the JSON of `sogdd eval chessboard`). "
        "GFTT + cornerSubPix (5, 5) is the practitioner's pipeline; findChessboardCornersSB needs the "
        "pattern size and returns all corners or none.\n",
        "**What differs from the paper:** nothing to compare; the paper has no checkerboard experiment. "
        "Dense X-corners are where 'high-resolution' corners matter most in practice (an earlier study "
        "found that at an X-corner, a saddle point, SOGDD's Υ has a local minimum ringed by maxima about "
        "2 px away). sogdd's recall at 1 px here: "
        + ", ".join(f"{(sog.get(f'{c:g}') or {}).get('recall', float('nan')):.2f} at {c:g} px" for c in small)
        + ".\n",
        rep.table(),
        f"\n![chessboard]({page.rel}/chessboard.png)\n",
    ]
    if real is not None:
        page.md += [
            "\n### Real calibration photos\n",
            "`calibration/` (BoofCV's hand-labelled Sony frames; labels of undocumented pixel convention, so "
            f"one global offset per data set is removed: {real['offset_method']}).\n",
            real_markdown(real),
        ]
    page.summary["chessboard"] = {"quick": quick, "recall": recall}


def _list(v) -> str:
    return ", ".join(f"{x:g}" for x in v)


def _mean(v: list[float]) -> float:
    return float(sum(v) / len(v)) if v else float("nan")


