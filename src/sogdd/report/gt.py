"""The GT evaluation's outputs: Table 1-style tables, overlay montages (Figs. 7/8), files."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..evaluation.gt.data import GTSet
from ..evaluation.gt.protocol import GTReport
from .overlays import montage, overlay_gt, save_png
from .tables import gt_csv, gt_summary_table, gt_table, markdown_table, paper_table1

__all__ = ["PAPER_ROWS", "gt_overlay_montage", "paper_vs_ours", "write_gt_outputs"]

# The paper's Table 1 rows and the registry names that implement them.
PAPER_ROWS = {"Harris": "harris", "Harris-Laplace": "harris-laplace", "FAST": "fast",
              "Zhang(2013)": "zhang2013", "Zhang(2021)": "zhang2021", "Proposed": "sogdd"}


def gt_overlay_montage(rep: GTReport, gt_set: GTSet, detectors: list[str] | None = None,
                       setting: str = "tuned", tile_width: int = 320) -> np.ndarray:
    """Figs. 7/8 style: one tile per detector at its ``tuned`` or ``joint`` threshold."""
    dets = detectors or rep.detectors()
    h, w = gt_set.image.shape[:2]
    scale = min(1.0, tile_width / w)
    tiles = []
    for d in dets:
        e = rep.entry(d, gt_set.name)
        if setting == "default":
            xy = e.default_corners.xy
        else:
            t = e.tuned_threshold if setting == "tuned" else rep.joint_threshold[d]
            xy = e.corners_at(t).xy
        tiles.append(overlay_gt(gt_set.image, gt_set.corners, xy, rep.delta, scale, d))
    return montage(tiles, columns=3)


def write_gt_outputs(rep: GTReport, sets: list[GTSet], out: Path) -> list[Path]:
    """``gt.md``, ``gt.csv``, ``gt.json`` and ``overlays/<image>.png`` under ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    md = ["# Ground-truth accuracy\n", f"delta = {rep.delta} px\n", "## All images pooled\n",
          gt_summary_table(rep)]
    for which in ("tuned", "joint", "default"):
        md += [f"\n## Per image, {which} threshold\n", gt_table(rep, which)]
    (out / "gt.md").write_text("\n".join(md))
    (out / "gt.csv").write_text(gt_csv(rep))
    (out / "gt.json").write_text(json.dumps(rep.to_json(), indent=1))
    files = [out / "gt.md", out / "gt.csv", out / "gt.json"]
    for s in sets:
        files.append(save_png(out / "overlays" / f"{s.name}.png", gt_overlay_montage(rep, s)))
    return files


def paper_vs_ours(rep: GTReport, paper_csv: Path | None) -> str:
    """Our per-image tuned Geometric row beside the paper's Table 1 (empty without that image)."""
    if "geometric" not in rep.images:
        return ""
    rows = []
    paper = {r["detector"]: r for r in paper_table1(paper_csv)} if paper_csv else {}
    for prow, name in PAPER_ROWS.items():
        if name not in rep.detectors():
            continue
        e = rep.entry(name, "geometric")
        p = paper.get(prow, {})
        rows.append([prow, name, p.get("missed_geometric", "–"), e.tuned.missed,
                     p.get("false_geometric", "–"), e.tuned.false,
                     float(p["le_geometric"]) if "le_geometric" in p else None, e.tuned.le])
    header = ["paper row", "ours", "missed (paper, 114 GT)", "missed (ours, 84 GT)",
              "false (paper)", "false (ours)", "Le (paper)", "Le (ours)"]
    return markdown_table(header, rows, "ll" + "r" * 6)
