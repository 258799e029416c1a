"""The calibration-target evaluation's tables and figure (``sogdd eval calibration``'s results), and its section
of the results page.

The command writes ``calibration.json`` (:func:`write_results`), ``calibration.md``
(:func:`results_markdown`) and ``calibration.png`` (:func:`calibration_figure`);
the results page reads the JSON back (:func:`calibration_stage`) from
``figures/calibration/`` next to the page and never runs the evaluation itself
(it takes minutes).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from ..formats.safe_write import write_text
from .tables import markdown_table

__all__ = ["calibration_figure", "calibration_stage", "merge_results", "results_markdown", "write_results"]

_JSON = "calibration.json"
_PNG = "calibration.png"


def _f(v, fmt: str = ".3f") -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "–"
    return format(v, fmt)


def _boards(r: dict) -> str:
    if r.get("kind") != "board":
        return "–"
    return f"{r['boards']} of {r['frames']}"


def synthetic_table(rows: list[dict]) -> str:
    """One line per (sequence, method): boards, recall, wrong labels, corner error, calibration, time."""
    table = []
    for r in rows:
        c = r["corner"]
        cal = r.get("calibration") or {}
        table.append([r["sequence"], f"`{r['method']}`", _boards(r), _f(r["recall"], ".3f"),
                      "–" if r.get("kind") != "board" else str(r["wrong_labels"]),
                      _f(c["mean"], ".4f"), _f(c["rms"], ".4f"), _f(c["p95"], ".3f"), _f(c["max"], ".3f"),
                      _f(cal.get("projection_difference"), ".3f"), _f(cal.get("focal_error"), ".2f"),
                      _f(cal.get("rms"), ".4f"), _f(r.get("ms_per_frame"), ".0f")])
    return markdown_table(["sequence", "method", "boards", "recall", "wrong labels", "corner mean", "RMS",
                           "p95", "max", "proj. diff.", "fx error", "RMS reproj.", "ms/frame"], table)


def real_table(rows: list[dict]) -> str:
    """One line per (photo set, method): boards, label distance after one offset, RMS, fx."""
    table = []
    for r in rows:
        off = r.get("offset") or [None, None]
        fx = "–" if "fx" not in r else f"{_f(r.get('fx'), '.1f')} ({_f(r.get('fx_reference'), '.1f')})"
        boards = "–" if r["kind"] != "board" else f"{r['boards']} of {r['images']}"
        table.append([r["set"], f"`{r['method']}`", boards,
                      _f(r.get("label_distance"), ".3f"), f"({_f(off[0], '+.2f')}, {_f(off[1], '+.2f')})",
                      _f(r.get("rms"), ".4f"), fx, _f(r.get("ms_per_frame"), ".0f")])
    return markdown_table(["set", "method", "boards", "label distance", "offset removed", "RMS reproj.",
                           "fx (BoofCV)", "ms/frame"], table)


def results_markdown(res: dict) -> str:
    """The results as Markdown: notes, the rendered sequences' table, the real photos' table."""
    out = []
    if res.get("notes"):
        out.append("\n".join(f"- {n}" for n in res["notes"]) + "\n")
    seqs = res.get("sequences") or {}
    if seqs:
        out.append("Sequences: " + "; ".join(f"**{k}**: {v}" for k, v in seqs.items()) + ".\n")
    if res.get("synthetic"):
        out.append(synthetic_table(res["synthetic"]))
    if res.get("real"):
        out.append("\nReal photos (6 x 4 inner corners; hand labels good to about 0.2 px):\n")
        out.append(real_table(res["real"]))
    return "\n".join(out)


def merge_results(old: dict, new: dict) -> dict:
    """``new`` added to ``old``: rows of the same (sequence or set, method) replaced, the rest kept, in order.

    The commands, notes and sequences of both are kept; ``seconds`` adds up.

    Examples
    --------
    >>> a = {"command": "A", "synthetic": [{"sequence": "s", "method": "m", "v": 1}], "real": [], "seconds": 2}
    >>> b = {"command": "B", "synthetic": [{"sequence": "s", "method": "m", "v": 2},
    ...                                    {"sequence": "t", "method": "m", "v": 3}], "real": [], "seconds": 1}
    >>> m = merge_results(a, b)
    >>> [r["v"] for r in m["synthetic"]], m["commands"], m["seconds"]
    ([2, 3], ['A', 'B'], 3)
    """
    out = dict(new)
    for key, ident in (("synthetic", "sequence"), ("real", "set")):
        rows = {(r[ident], r["method"]): r for r in old.get(key) or []}
        for r in new.get(key) or []:
            rows[(r[ident], r["method"])] = r
        out[key] = list(rows.values())
    out["commands"] = list(old.get("commands") or [old.get("command")]) + [new.get("command")]
    out["notes"] = list(dict.fromkeys((old.get("notes") or []) + (new.get("notes") or [])))
    out["sequences"] = {**(old.get("sequences") or {}), **(new.get("sequences") or {})}
    out["seconds"] = (old.get("seconds") or 0) + (new.get("seconds") or 0)
    return out


def write_results(res: dict, out: str | Path, *, merge: bool = False) -> Path:
    """Write ``calibration.json``, ``calibration.md`` and ``calibration.png`` into ``out``; the JSON's path.

    ``merge``: add ``res`` to the ``calibration.json`` already there (:func:`merge_results`).
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / _JSON
    if merge and path.is_file():
        res = merge_results(json.loads(path.read_text()), res)
    write_text(path, json.dumps(res, indent=1))
    write_text(out / "calibration.md", results_markdown(res))
    if res.get("synthetic"):
        calibration_figure(res, out / _PNG)
    return path


def calibration_figure(res: dict, path: str | Path) -> Path:
    """Two panels per rendered sequence set: mean corner error and projection difference, per method."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = res["synthetic"]
    seqs = list(dict.fromkeys(r["sequence"] for r in rows))
    methods = list(dict.fromkeys(r["method"] for r in rows))
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
    width = 0.8 / max(1, len(methods))
    positive = [False, False]
    for k, m in enumerate(methods):
        by = {r["sequence"]: r for r in rows if r["method"] == m}
        xs = [i + (k - (len(methods) - 1) / 2) * width for i in range(len(seqs))]
        err = [_nan(by.get(s, {}).get("corner", {}).get("mean")) for s in seqs]
        pd = [_nan((by.get(s, {}).get("calibration") or {}).get("projection_difference")) for s in seqs]
        for a, values in enumerate((err, pd)):
            axes[a].bar(xs, values, width, label=m)
            positive[a] |= any(v > 0 for v in values)  # NaN compares False
    for ax, title, pos in zip(axes, ("mean corner error (px)", "projection difference to the true camera (px)"),
                              positive):
        ax.set_xticks(range(len(seqs)))
        ax.set_xticklabels(seqs)
        if pos:  # a log axis needs a positive value (the stress scenes are not calibrated: no differences)
            ax.set_yscale("log")
        ax.set_title(title)
        ax.grid(True, axis="y", alpha=0.3)
    axes[0].axhline(0.015, color="k", ls="--", lw=0.8, label="0.015 px")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 10), fontsize=8, frameon=False)
    fig.suptitle("Rendered calibration sequences" + (" (quick set)" if res.get("quick") else ""))
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _nan(v) -> float:
    return float("nan") if v is None else float(v)


def calibration_stage(page, runs: Path) -> None:
    """The results page's calibration section, from ``runs/calibration.json`` (or how to make it)."""
    path = Path(runs) / _JSON
    page.md.append("\n## Calibration targets (beyond the paper)\n")
    if not path.is_file():
        page.md.append(f"No results yet: `sogdd eval calibration --out {runs}` makes them "
                       "(rendered sequences with an exactly known camera and the real calibration photos).\n")
        return
    res = json.loads(path.read_text())
    page.md += [
        f"Read from `{path}`, made by "
        + ", ".join(f"`{c}`" for c in res.get("commands") or [res.get("command", "sogdd eval calibration")])
        + " "
        f"(sogdd {res.get('version', '?')}, {res.get('seconds', 0):.0f} s). Rendered views through an exactly "
        "known pinhole camera with k1, k2, p1, p2 (4 x 4 supersampled, blur, falloff, noise); corner error "
        "against the projected truth after each view's best label alignment; projection difference: the mean "
        "distance over the image between where the calibrated and the true camera put the same ray "
        "(`sogdd.calib.projection_difference`), averaged over the noise draws.\n",
        results_markdown(res),
    ]
    png = Path(runs) / _PNG
    if png.is_file():
        import os

        page.md.append(f"\n![calibration]({os.path.relpath(png, page.figs.parent.parent)})\n")
    page.summary["calibration"] = {"file": str(path)}
