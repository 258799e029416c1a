"""The matching evaluation's table and figure: MMA and homography AUC per split (Markdown), MMA curves."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..evaluation.matching.protocol import SPLITS, THRESHOLDS

__all__ = ["budget_table", "homography_table", "matching_markdown", "plot_mma"]


def matching_markdown(results: dict, info: dict) -> str:
    """Markdown table of a matching run: MMA at 1, 3, 5, 10 px and H AUC at 1, 3, 5 px per split."""
    full = "the full D2-Net HPatches benchmark" if info["full_hpatches"] else "NOT the full HPatches benchmark"
    lines = [
        f"Sequences: {info['n_sequences']} ({info['n_illumination']} illumination, "
        f"{info['n_viewpoint']} viewpoint), {info['n_pairs']} pairs; layout {info['layout']}; {full}. "
        f"Descriptor: {info['descriptor']}.",
        "",
        "| detector | split | MMA@1 | MMA@3 | MMA@5 | MMA@10 | H AUC@1 | H AUC@3 | H AUC@5 | "
        "features | matches |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for label, s in results.items():
        n_all = s["pairs"]["overall"]
        for split, curve in s["mma"].items():
            if curve is None:
                continue
            if split != "overall" and s["pairs"][split] == n_all:
                continue  # the only split present: its row would repeat the overall row
            name = split
            if split == "overall":
                only = [k for k in ("illumination", "viewpoint") if s["pairs"][k] == n_all]
                name = f"overall (all {only[0]})" if only else "overall"
            auc = (s.get("homography") or {}).get("auc", {}).get(split) or [None] * 3
            lines.append(
                f"| `{label}` | {name}, {s['pairs'][split]} pairs | {curve[0]:.3f} | {curve[2]:.3f} | "
                f"{curve[4]:.3f} | {curve[9]:.3f} | " + " | ".join(_f(a) for a in auc)
                + f" | {s['features']:.0f} | {s['matches']:.0f} |"
            )
    lines += ["", "H AUC@t: a homography is estimated from each pair's matches (MAGSAC++, "
              "`sogdd.evaluation.matching.homography`); the mean error of the reference image's four "
              "corners is integrated as in SuperGlue/LoFTR (area under the cumulative error curve up to "
              "t px, over t; a failed estimate counts as an infinite error). Not in D2-Net's protocol."]
    return "\n".join(lines) + "\n"


def homography_table(paths: list[Path]) -> str:
    """One table over several runs (``matching.json`` files): MMA@3 and H AUC@1/3/5 per layout.

    Rows are the detectors of the first run (others' extra detectors follow);
    each run gives a column group named by its layout and pair count. Runs
    without homography results show dashes. Empty string without runs.
    """
    import json

    runs = []
    for p in paths:
        obj = json.loads(Path(p).read_text())
        info = next(iter(obj.values()))["benchmark"] if obj else {}
        seqs = info.get("sequences", [])
        name = info.get("layout", Path(p).parent.name) + (f" `{seqs[0]}`" if len(seqs) == 1 else "")
        runs.append((f"{name} ({info.get('n_pairs', '?')} pairs)", obj))
    if not runs:
        return ""
    labels = list(dict.fromkeys(lab for _, obj in runs for lab in obj))
    head = "| detector | " + " | ".join(f"{n}: MMA@3 / H AUC@1 / @3 / @5 / median corner err."
                                       for n, _ in runs) + " |"
    lines = [head, "|---|" + "---|" * len(runs)]
    for lab in labels:
        cells = []
        for _, obj in runs:
            s = obj.get(lab)
            if s is None:
                cells.append("–")
                continue
            hom = s.get("homography") or {}
            auc = (hom.get("auc") or {}).get("overall") or [None] * 3
            med = hom.get("median_corner_error")
            failed = hom.get("failed")
            cells.append(f"{_f(s['mma']['overall'][2])} / " + " / ".join(_f(a) for a in auc)
                         + f" / {_f(med, 2)}" + (f" ({failed} failed)" if failed else ""))
        lines.append(f"| `{lab}` | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n\n" + (
        "H AUC@t: area under the cumulative curve of the pairs' mean corner errors up to t px, over t "
        "(SuperGlue's `pose_auc`, used by LoFTR on HPatches); H from the mutual-NN matches by MAGSAC++ "
        "(`cv2.USAC_MAGSAC`, 3 px); a failed estimate counts as an infinite error. Median corner error in "
        "px over the pairs. With 5 to 8 pairs per set, one pair moves an AUC by 0.1 to 0.2.\n")


def _set_name(info: dict, fallback: str) -> str:
    seqs = info.get("sequences", [])
    return info.get("layout", fallback) + (f" `{seqs[0]}`" if len(seqs) == 1 else "")


def _base_key(s: dict) -> str:
    """A detector without its top-k: the key that pairs a budget run with the default run."""
    import json

    spec = s.get("spec") or {}
    return json.dumps([spec.get("detector"), spec.get("params"), spec.get("remove_border"),
                       spec.get("descriptor"), spec.get("desc_size")], sort_keys=True, default=str)


def budget_table(paths: list[Path]) -> str:
    """Matching at an equal budget beside the detectors' defaults: MMA@1 / MMA@3 (features) per set.

    ``paths`` are ``matching.json`` files; a run made with ``--max-features N``
    records ``budget: N`` in every result. Rows are the detectors that have a
    budget result; each set (layout and sequence) gives two columns, the
    detector at its defaults and at the budget. A default run is paired with a
    budget run of the same detector, parameters, border and descriptor (its own
    ``top_k`` aside; the run without one is preferred). Empty string when no
    run has a budget.
    """
    import json

    sets: dict[str, dict] = {}
    for p in paths:
        obj = json.loads(Path(p).read_text())
        for label, s in obj.items():
            name = _set_name(s.get("benchmark") or {}, Path(p).parent.name)
            cell = sets.setdefault(name, {"n_pairs": (s.get("benchmark") or {}).get("n_pairs", "?"),
                                          "default": {}, "budget": {}})
            key = _base_key(s)
            if s.get("budget"):
                cell["budget"][key] = (label, s)
            elif key not in cell["default"] or (s.get("spec") or {}).get("top_k") is None:
                cell["default"][key] = (label, s)
    budgets = sorted({s["budget"] for c in sets.values() for _, s in c["budget"].values()})
    if not budgets:
        return ""
    names = [n for n, c in sets.items() if c["budget"]]
    keys = list(dict.fromkeys(k for n in names for k in sets[n]["budget"]))

    def cell(entry) -> str:
        if entry is None:
            return "–"
        s = entry[1]
        return f"{_f(s['mma']['overall'][0])} / {_f(s['mma']['overall'][2])} ({s['features']:.0f})"

    n_txt = ", ".join(str(b) for b in budgets)
    head = "| detector | " + " | ".join(f"{n} ({sets[n]['n_pairs']} pairs): defaults | at {n_txt}"
                                       for n in names) + " |"
    lines = [head, "|---|" + "---|---|" * len(names)]
    for k in keys:
        label = next((sets[n]["default"][k][0] for n in names if k in sets[n]["default"]), None)
        if label is None:
            label = next(sets[n]["budget"][k][0] for n in names if k in sets[n]["budget"])
        cells = [f"{cell(sets[n]['default'].get(k))} | {cell(sets[n]['budget'].get(k))}" for n in names]
        lines.append(f"| `{label}` | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n\n" + (
        f"MMA@1 / MMA@3 (mean features per image), overall. **At {n_txt}**: every detector keeps its "
        f"{n_txt} strongest points per image (`sogdd eval matching --max-features N`), so the detectors are "
        "compared at equal counts; a detector that finds fewer keeps all of its points (the count shows it). "
        "At their defaults the detectors return between a few hundred and ten thousand points, and MMA "
        "falls as the count grows.\n")


def _f(v, digits: int = 3) -> str:
    return "–" if v is None else f"{v:.{digits}f}"


def plot_mma(
    results: dict[str, dict],
    path: str | Path,
    *,
    published: dict[str, dict[str, dict]] | None = None,
    full_benchmark: bool = False,
    title: str = "",
) -> Path:
    """MMA against threshold, one panel per split (Fig. 10's layout).

    ``results`` maps a label to a :meth:`MatchingResult.summary` dict.
    Published curves, if given, are drawn dashed and grey-toned, and labelled
    as the full HPatches benchmark unless ``full_benchmark`` says the local run
    is that benchmark too.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.asarray(THRESHOLDS)
    tag = "" if full_benchmark else " [published; full HPatches: a different data set]"
    n_pub = len(published or {})
    n_leg = len(results) + n_pub
    ncol = 3
    rows = -(-n_leg // ncol)
    height = 4.0 + 0.2 * rows + 0.4
    fig, axes = plt.subplots(1, 3, figsize=(14, height), sharey=True)
    cmap = plt.get_cmap("tab20")
    greys = plt.get_cmap("Greys")
    for ax, split in zip(axes, SPLITS):
        if published:
            for k, (meth, splits) in enumerate(sorted(published.items())):
                if split in splits:
                    grey = greys(0.35 + 0.6 * k / max(n_pub, 1))
                    ax.plot(t, splits[split]["mma"], ls="--", lw=1.0, color=grey,
                            label=f"{meth}{tag}" if split == "overall" else None)
        n_pairs = None
        for k, (label, s) in enumerate(results.items()):
            curve = s["mma"].get(split)
            if curve is None:
                continue
            n_pairs = s["pairs"][split]
            ours = label.startswith("sogdd")
            ax.plot(t, curve, lw=2.6 if ours else 1.4, marker="o", ms=3.5 if ours else 2, color=cmap(k % 20),
                    zorder=3 if ours else 2,
                    label=f"{label} ({s['features']:.0f} feat., {s['matches']:.0f} matches)"
                    if split == "overall" else None)
        ax.set_title(f"{split} ({n_pairs} pairs)" if n_pairs else f"{split} (no local pairs)")
        ax.set_xlabel("threshold [px]")
        ax.set_xlim(1, 10)
        ax.set_ylim(0, 1)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("MMA")
    if title:
        fig.suptitle(title)
    handles, labels = axes[0].get_legend_handles_labels()
    # local results first, then the published curves
    order = [i for i, lab in enumerate(labels) if "[published" not in lab] + [
        i for i, lab in enumerate(labels) if "[published" in lab]
    fig.legend([handles[i] for i in order], [labels[i] for i in order], loc="lower center", ncol=ncol,
               fontsize=7.5, frameon=False)
    fig.tight_layout(rect=(0, (0.2 * rows + 0.3) / height, 1, 1))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path
