"""The SfM evaluation's table: Table 2's layout, our rows beside the paper's."""

from __future__ import annotations

import csv
from pathlib import Path

__all__ = ["paper_rows", "sfm_markdown"]


def paper_rows(path: str | Path | None, dataset: str) -> list[dict]:
    """The paper's Table 2 rows for ``dataset`` from ``paper_table2.csv`` (none without a file)."""
    if path is None or not Path(path).is_file():
        return []
    aliases = {"fountain-p11": "Fountain", "herz-jesus-p8": "Herzjesu"}
    want = aliases.get(dataset.lower(), dataset)
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(line for line in fh if not line.startswith("#")))
    return [r for r in rows if r["dataset"].lower() == want.lower()]


def _fmt(v, nd=2):
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.{nd}f}"
    return str(v)


def sfm_markdown(obj: dict, dataset: str, paper_csv: str | Path | None = None) -> str:
    """Table 2-style Markdown: our rows, then the paper's rows for the same data set (from ``paper_csv``)."""
    lines = [
        f"Data set: {dataset}",
        "",
        "| method | source | #reg. images | #sparse points | #dense points | track length | reproj. error (px) "
        "| features/img | seconds | rot. err. (deg, median) | pos. err. (median) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for label, r in obj.items():
        pe = r.get("pose_errors") or {}
        dense = r.get("dense_points")
        gpu = r.get("dense_points_gpu")  # added by a separate run on a CUDA machine, if any
        if gpu:
            dense = f"{gpu['points']} (CUDA run, images <= {gpu['max_image_size']} px)"
        lines.append(
            f"| `{label}` | this run | {r['registered']}/{r['images']} | {r['points']} | "
            f"{dense} | "
            f"{_fmt(r.get('track_length'))} | {_fmt(r.get('reproj_error'))} | {r['features']:.0f} | "
            f"{_fmt(r.get('seconds'), 1)} | {_fmt(pe.get('rotation_deg_median'), 3)} | "
            f"{_fmt(pe.get('position_median'), 4)} |"
        )
    for p in paper_rows(paper_csv, dataset):
        lines.append(
            f"| {p['method']} | paper, Table 2 | {p['registered']}/{p['images']} | {p['sparse_points']} | "
            f"{p['dense_points']} | {p['track_length']} | {p['reproj_error_px']} | - | - | - | - |"
        )
    return "\n".join(lines) + "\n"
