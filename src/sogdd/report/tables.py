"""Markdown and CSV tables of the evaluations."""

from __future__ import annotations

import csv
import io
import math
import os
from pathlib import Path

from ..evaluation.gt.protocol import GTReport
from ..evaluation.repeatability.protocol import RepeatabilityReport, top_n_label
from ..evaluation.repeatability.transforms import FAMILIES as PAPER_FAMILIES
from ..evaluation.resolution.protocol import ResolutionReport

__all__ = ["markdown_table", "gt_table", "gt_summary_table", "gt_readme_table", "gt_csv", "paper_table1",
           "rank_of", "repeatability_table", "repeatability_modes_table", "resolution_table", "fmt"]


def rank_of(scores: dict[str, float], name: str, higher_is_better: bool = True) -> tuple[int, int]:
    """``(rank, count)`` of ``name`` among ``scores`` (1 = best; NaN and None rank last).

    Examples
    --------
    >>> rank_of({"a": 0.5, "b": 0.9, "c": float("nan")}, "a")
    (2, 3)
    """
    def key(d):
        v = scores[d]
        if v is None or not math.isfinite(v):
            return math.inf
        return -v if higher_is_better else v
    order = sorted(scores, key=key)
    return order.index(name) + 1, len(order)


def fmt(v, digits: int = 3) -> str:
    """Numbers for tables: integers as is, floats rounded, NaN/None as an en dash."""
    if v is None:
        return "–"
    if isinstance(v, bool):
        return str(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            return "–"
        if v != 0 and (abs(v) >= 1e5 or abs(v) < 1e-3):
            return f"{v:.3g}"
        return f"{v:.{digits}f}"
    return str(v)


def markdown_table(header: list[str], rows: list[list], align: str | None = None) -> str:
    """A GitHub Markdown table; ``align`` is one of 'l', 'r', 'c' per column."""
    al = align or ("l" + "r" * (len(header) - 1))
    sep = {"l": ":---", "r": "---:", "c": ":---:"}
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join(sep[a] for a in al) + "|"]
    for r in rows:
        lines.append("| " + " | ".join(fmt(v) for v in r) + " |")
    return "\n".join(lines) + "\n"


def gt_table(rep: GTReport, setting: str = "tuned", images: list[str] | None = None) -> str:
    """Table 1 layout: missed, false and Le per image (columns) for every detector (rows).

    ``setting``: ``default``, ``tuned`` (per image) or ``joint`` (one threshold).
    The last columns pool all images of ``images`` (all by default).
    """
    imgs = images or rep.images
    header = ["detector"] + [f"missed {i}" for i in imgs] + [f"false {i}" for i in imgs] \
        + [f"Le {i}" for i in imgs] + ["F1 (all)"]
    rows = []
    for d in rep.detectors():
        es = {e.image: getattr(e, setting) for e in rep.entries if e.detector == d}
        pooled = rep.pooled(d, setting)
        rows.append([d] + [es[i].missed for i in imgs] + [es[i].false for i in imgs]
                    + [es[i].le for i in imgs] + [pooled.f1])
    return markdown_table(header, rows)


def gt_summary_table(rep: GTReport) -> str:
    """All images pooled: missed + false, Le and F1 at the three operating points."""
    header = ["detector", "GT", "default M+F", "default Le", "default F1", "tuned M+F",
              "tuned Le", "tuned F1", "joint M+F", "joint Le", "joint F1", "joint threshold",
              "sweep consistency"]
    rows = []
    for d in rep.detectors():
        r = [d, sum(rep.n_gt.values())]
        for which in ("default", "tuned", "joint"):
            m = rep.pooled(d, which)
            r += [m.missed + m.false, m.le, m.f1]
        cons = [e.consistency for e in rep.entries if e.detector == d]
        rows.append(r + [rep.joint_threshold.get(d), float(sum(cons) / len(cons))])
    return markdown_table(header, rows)


def gt_readme_table(rep: GTReport, keep: tuple[str, ...] = ("sogdd", "sogdd-authors", "sogdd-hr"),
                    top: int = 5) -> str:
    """The README's GT summary: the ``top`` detectors by one-threshold missed + false, and ``keep``.

    Columns: default M+F and F1, per-image tuned M+F, one threshold (joint) M+F and F1; rows by
    joint M+F, sogdd's presets in bold.
    """
    joint = {d: rep.pooled(d, "joint") for d in rep.detectors()}
    order = sorted(joint, key=lambda d: (joint[d].missed + joint[d].false, d))
    names = [d for d in order if d in order[:top] or d in keep]
    rows = []
    for d in names:
        de, tu, jo = (rep.pooled(d, w) for w in ("default", "tuned", "joint"))
        label = f"**{d}**" if d.startswith("sogdd") else d
        rows.append([label, de.missed + de.false, de.f1, tu.missed + tu.false, jo.missed + jo.false, jo.f1])
    header = ["detector", "default M+F", "default F1", "tuned per image M+F", "one threshold M+F",
              "one-threshold F1"]
    return markdown_table(header, rows)


def gt_csv(rep: GTReport) -> str:
    """Every record of :meth:`GTReport.rows` as CSV."""
    rows = rep.rows()
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(rows[0]) if rows else ["detector"])
    w.writeheader()
    for r in rows:
        w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})
    return buf.getvalue()


def paper_table1(path: str | os.PathLike) -> list[dict]:
    """Read the paper's Table 1 (``shared/reference/paper_table1.csv``)."""
    lines = [ln for ln in Path(path).read_text().splitlines() if ln and not ln.startswith("#")]
    return list(csv.DictReader(lines))


def _family_header(f: str) -> str:
    return f if f in PAPER_FAMILIES else f"{f} (beyond the paper)"


def repeatability_table(rep: RepeatabilityReport, detectors: list[str] | None = None) -> str:
    """Family averages of R_avg (rows: detectors, best overall first).

    ``overall`` is the mean of the paper's families; a family beyond the paper
    (``blur``) has its own column, marked, outside that mean.
    """
    summ = rep.summary()
    order = sorted(detectors or rep.detectors, key=lambda d: -summ[d]["overall"])
    header = ["rank", "detector"] + [_family_header(f) for f in rep.families] + ["overall (paper families)"]
    rows = [[i + 1, d] + [summ[d][f] for f in rep.families] + [summ[d]["overall"]]
            for i, d in enumerate(order)]
    return markdown_table(header, rows, "rl" + "r" * (len(rep.families) + 1))


def repeatability_modes_table(rep: RepeatabilityReport) -> str:
    """Both modes side by side: at defaults and with the N strongest points (``rep.top_n``).

    Per spec: mean points per image, overall R_avg (paper families) and each
    family beyond the paper, in each mode; rows by the fixed-count overall.
    """
    if rep.top_n is None:
        return repeatability_table(rep)
    n, summ, points = rep.top_n, rep.summary(), rep.points()
    extra = [f for f in rep.families if f not in PAPER_FAMILIES]
    top = {s: top_n_label(s, n) for s in rep.specs}
    order = sorted(rep.specs, key=lambda s: -summ[top[s]]["overall"])
    header = ["detector", "default: points", "default: overall"] + [f"default: {f}†" for f in extra] \
        + [f"top-{n}: points", f"top-{n}: overall"] + [f"top-{n}: {f}†" for f in extra]
    rows = []
    for s in order:
        d, t = summ[s], summ[top[s]]
        pts = [round(points[x]) if points[x] == points[x] else None for x in (s, top[s])]
        rows.append([s, pts[0], d["overall"]] + [d[f] for f in extra]
                    + [pts[1], t["overall"]] + [t[f] for f in extra])
    note = ("\n† beyond the paper: not in the overall mean.\n" if extra else "")
    return markdown_table(header, rows) + note


def resolution_table(rep: ResolutionReport) -> str:
    """Resolution rate per corner distance d, mean rate, Le and d50."""
    ds = rep.ds()
    header = ["detector"] + [f"d={d:g}" for d in ds] + ["mean", "Le (px)", "d50"]
    rows = []
    for det in rep.detectors:
        r = rep.rate(det)
        rows.append([det] + [r.get(d) for d in ds] + [rep.mean_rate(det), rep.le(det),
                                                       rep.min_resolved_d(det)])
    return markdown_table(header, rows)
