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


def _spread(r: dict, key: str, nd: int) -> str:
    """``median (min–max)`` over the seeds where the run has them, else the single value."""
    sp = (r.get("spread") or {}).get(key)
    if key in ("rotation_deg_median", "position_median"):
        v = r.get(key, (r.get("pose_errors") or {}).get(key))
    else:
        v = r.get(key)
    if not sp:
        return _fmt(v, nd) if key != "points" or v is None else str(int(round(v)))
    if key == "points":
        return f"{sp['median']:.0f} ({sp['min']:.0f}–{sp['max']:.0f})"
    return f"{sp['median']:.{nd}f} ({sp['min']:.{nd}f}–{sp['max']:.{nd}f})"


def sfm_markdown(obj: dict, dataset: str, paper_csv: str | Path | None = None) -> str:
    """Table 2-style Markdown: our rows, then the paper's rows for the same data set (from ``paper_csv``).

    Rows run over several seeds (``sogdd eval sfm --seeds``) show ``median (min–max)`` over the seeds
    for the points, the reprojection error and the median rotation and position errors; their
    registered count is the smallest over the seeds.
    """
    seeds = sorted({tuple(r["seeds"]) for r in obj.values() if r.get("seeds")})
    budgets = sorted({r["budget"] for r in obj.values() if r.get("budget")})
    notes = ([f"Seeds: {', '.join(','.join(map(str, s)) for s in seeds)}; numbers are the median over the "
              "seeds (min–max), #reg. images the smallest."] if seeds else [])
    notes += [f"Equal budget: every detector keeps its {', '.join(map(str, budgets))} strongest points per "
              "image."] if budgets else []
    lines = [
        f"Data set: {dataset}",
        *(["", *notes] if notes else []),
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
            f"| `{label}` | this run | {r['registered']}/{r['images']} | {_spread(r, 'points', 0)} | "
            f"{dense} | "
            f"{_fmt(r.get('track_length'))} | {_spread(r, 'reproj_error', 2)} | {r['features']:.0f} | "
            f"{_fmt(r.get('seconds'), 1)} | {_spread({**pe, **r}, 'rotation_deg_median', 3)} | "
            f"{_spread({**pe, **r}, 'position_median', 4)} |"
        )
    for p in paper_rows(paper_csv, dataset):
        lines.append(
            f"| {p['method']} | paper, Table 2 | {p['registered']}/{p['images']} | {p['sparse_points']} | "
            f"{p['dense_points']} | {p['track_length']} | {p['reproj_error_px']} | - | - | - | - |"
        )
    return "\n".join(lines) + "\n"
