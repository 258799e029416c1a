"""The results page (``sogdd report``): every evaluation that is fast enough, in Markdown.

:func:`build_report` runs its stages in order, each adding a section, ranks
for the summary and figures: :func:`gt_stage` (the GT protocol on
``<data>/corners_gt``), :func:`repeatability_stage` (``<data>/repeatability``,
quick grid by default, the paper's grid with ``full=True``; the learned
detectors' rows read from cached runs, :mod:`.learned_runs`),
:func:`~.resolution_section.resolution_stage` (the adjacent-corner benchmark;
cached full-grid runs when there are), :func:`~.chessboard_section.chessboard_stage`
(dense checkerboards, rendered and real), :func:`~.calibration_section.calibration_stage`
(calibration targets: read from ``figures/calibration/``, which ``sogdd eval calibration --out``
writes), :func:`~.fig1_section.fig1_stage`
(the paper's Fig. 1 on a real image) and :func:`downstream_stage` (matching,
with homography AUC beside MMA, and SfM runs already written). Where the
registry has ``sogdd-hr``, every section includes it. The page
goes to ``out_md`` with its figures in ``figures/results/`` next to it, and
states the version and commit that made it. The paper's Table 1 is shown
beside ours.
"""

from __future__ import annotations

import json
import os
import platform
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path

from .._version import __version__
from ..baselines import learned_extra
from ..evaluation.gt import evaluate_gt, find_gt_sets
from ..evaluation.repeatability import evaluate_repeatability, load_images, top_n_label
from ..evaluation.specs import LEARNED, DetectorSpec, default_fast_specs, default_gt_specs, registry_names
from .calibration_section import calibration_stage
from .chessboard_section import chessboard_stage
from .fig1_section import fig1_stage
from .gt import PAPER_ROWS, gt_overlay_montage, paper_vs_ours
from .learned_rows import learned_labels, learned_note
from .learned_runs import RUNS_DIR, cached_note, read_cached
from .matching import budget_table, homography_table
from .overlays import save_png
from .plots import repeatability_figure
from .readme_sync import sync_readme
from .resolution_section import resolution_stage
from .tables import (
    gt_readme_table,
    gt_summary_table,
    gt_table,
    rank_of,
    repeatability_modes_table,
    repeatability_table,
)

__all__ = ["Page", "build_report", "chessboard_stage", "downstream_stage", "fig1_stage", "gt_stage", "hr_names",
           "rank_of", "repeatability_stage", "resolution_stage"]

#: N of the fixed-count repeatability mode (the usual practice since Oxford / SuperPoint)
REPEATABILITY_TOP_N = 500


@dataclass
class Page:
    """What the stages build: Markdown sections, summary ranks, ``summary.json`` content, timings."""

    figs: Path
    rel: str
    full: bool = False
    jobs: int = 2
    progress: bool = True
    md: list[str] = field(default_factory=list)
    ranks: list[str] = field(default_factory=list)
    summary: dict = field(default_factory=dict)
    seconds: dict[str, float] = field(default_factory=dict)
    readme: dict[str, str] = field(default_factory=dict)  # README blocks from this run (report.readme_sync)


def hr_names() -> list[str]:
    """``["sogdd-hr"]`` where the registry has that detector (the high-resolution preset), else ``[]``."""
    return [n for n in ("sogdd-hr",) if n in registry_names()]


def gt_stage(page: Page, data: Path, paper_csv: Path | None) -> None:
    """Section 1: ground-truth accuracy (Table 1's protocol) on ``data/corners_gt``."""
    sets = find_gt_sets(data / "corners_gt")
    specs = default_gt_specs()
    t0 = time.perf_counter()
    gt = evaluate_gt(sets, specs, delta=2.0, progress=page.progress)
    page.seconds["gt"] = time.perf_counter() - t0
    table1_dets = [n for n in ["sogdd", "sogdd-authors", *PAPER_ROWS.values()]
                   if n in gt.detectors()]
    table1_dets = list(dict.fromkeys(table1_dets))
    for s in sets:
        if s.name in ("geometric", "block"):
            save_png(page.figs / f"gt_{s.name}.png",
                     gt_overlay_montage(gt, s, table1_dets, "tuned", tile_width=300))
    joint = {d: gt.pooled(d, "joint") for d in gt.detectors()}
    cost = {d: float(m.missed + m.false) for d, m in joint.items()}
    r, n = rank_of(cost, "sogdd", higher_is_better=False)
    page.ranks.append(f"GT accuracy (all {len(sets)} images, one threshold per detector, "
                 f"missed + false): sogdd ranks **{r} of {n}**")
    tuned_geo = {d: float(gt.entry(d, "geometric").tuned.missed
                          + gt.entry(d, "geometric").tuned.false)
                 for d in gt.detectors()} if "geometric" in gt.images else {}
    note = f"sogdd ranks {r} of {n} with one threshold"
    if tuned_geo:
        r2, n2 = rank_of(tuned_geo, "sogdd", higher_is_better=False)
        page.ranks.append(f"GT accuracy on Geometric (per-image tuned, the paper's setting): "
                     f"sogdd ranks **{r2} of {n2}**")
        g = gt.entry("sogdd", "geometric").tuned
        note += (f"; on Geometric alone, tuned per image (the paper's setting), it ranks {r2} of {n2} "
                 f"(missed {g.missed}, false {g.false}, Le {g.le:.2f} px)")
    page.readme["gt"] = gt_readme_table(gt) + "\n" + note + ".\n"
    page.md += [
        "## 1. Ground-truth accuracy (the protocol of Table 1)\n",
        f"Data: `corners_gt/` ({', '.join(f'{k} ({v} GT)' for k, v in gt.n_gt.items())}). "
        "A GT corner is matched to a detection within δ = 2 px, one to one, nearest first; "
        "unmatched GT corners are *missed*, unmatched detections *false*; Le is eq. 26 over "
        "the matched pairs. Each detector's threshold is swept over every distinct value of its "
        "response (one permissive run, see `sogdd.evaluation.gt.tuning`) and the operating point "
        "with the fewest missed + false is kept, ties broken by lower Le. *tuned* picks it per "
        "image (the paper's setting, optimistic); *joint* picks one threshold per detector for "
        "all images; *default* is the detector as shipped.\n",
        "### Pooled over all images\n", gt_summary_table(gt), learned_note(gt.detectors()),
        "\n### Geometric and block, per-image tuned threshold (Table 1 layout)\n",
        gt_table(gt, "tuned", [i for i in ("geometric", "block") if i in gt.images]),
        "\n### Beside the paper's Table 1 ('Geometric')\n",
        "**What differs from the paper:** the sets. The paper's Geometric has 114 GT corners, the public "
        "set used here 84, so the counts are not comparable; the paper's 'Table' image is not available. "
        "The paper's δ and tuning rule are used. The Geometric and block GT positions are "
        "integers (hand-labelled pixels), which favours detectors that report integer "
        "positions in Le; the shape sets have sub-pixel GT.\n",
        paper_vs_ours(gt, paper_csv),
        "\nOverlays at the per-image tuned threshold (green circle: matched GT; red square: "
        "missed GT; blue cross: false detection):\n",
    ]
    for s in ("geometric", "block"):
        if (page.figs / f"gt_{s}.png").exists():
            page.md.append(f"![{s}]({page.rel}/gt_{s}.png)\n")
    page.summary["gt_joint"] = {d: {"missed": m.missed, "false": m.false, "le": m.le if m.matched else None,
                                    "f1": m.f1} for d, m in joint.items()}


def repeatability_stage(page: Page, data: Path, learned_runs: str | os.PathLike | None = None) -> None:
    """Section 2: average repeatability (Fig. 9's protocol) on ``data/repeatability``.

    The learned detectors are not run here: their rows are read from the
    cached runs in ``learned_runs`` (default: ``figures/repeatability_learned``
    next to the page) whose protocol is the one just run
    (:mod:`sogdd.report.learned_runs`).
    """
    rep_dir = data / "repeatability"
    images = load_images(rep_dir)
    rspecs = [s for s in default_fast_specs() if s.name not in LEARNED]
    rspecs[1:1] = [DetectorSpec("sogdd-authors")] + [DetectorSpec(n) for n in hr_names()]
    rr = evaluate_repeatability(images, rspecs, quick=not page.full, jobs=page.jobs, progress=page.progress,
                                top_n=REPEATABILITY_TOP_N)
    live_seconds = rr.seconds
    cached = read_cached(Path(learned_runs) if learned_runs else page.figs.parent / RUNS_DIR, rr)
    if cached.report is not None:
        rr = rr.merged(cached.report)
    repeatability_figure(rr, page.figs / "repeatability.png", rr.specs)
    summ = rr.summary()
    r, n = rank_of({d: summ[d]["overall"] for d in rr.specs}, "sogdd")
    page.ranks.append(f"Repeatability ({'full' if page.full else 'quick'} grid, overall R_avg): "
                 f"sogdd ranks **{r} of {n}**")
    fam_ranks = ", ".join(
        f"{f} {rank_of({d: summ[d][f] for d in rr.specs}, 'sogdd')[0]}"
        for f in rr.families)
    tops = {d: top_n_label(d, REPEATABILITY_TOP_N) for d in rr.specs}
    r_top, _ = rank_of({tops[d]: summ[tops[d]]["overall"] for d in rr.specs}, tops["sogdd"])
    page.ranks.append(f"Repeatability, {REPEATABILITY_TOP_N} strongest points per image (thresholds off): "
                      f"sogdd ranks **{r_top} of {n}**")
    grid_name = "the paper's full grid" if page.full else "the quick grid (`--quick`)"
    page.md += [
        "\n## 2. Average repeatability (the protocol of Fig. 9)\n",
        f"Data: {len(images)} images (`repeatability/`, Awrangjeb & Lu); the paper used 30. Grid: {grid_name}; "
        "each detector at its defaults. Geometric transforms about the image centre with "
        "bilinear resampling on a canvas holding the whole transformed image; corners matched "
        "within 4 px one to one, counting only points whose mapped position lies inside the "
        "other image; R_avg is eq. 27, averaged per family over images and parameters. "
        f"Run time: {live_seconds:.0f} s with {page.jobs} processes.\n",
        repeatability_table(rr, rr.specs),
        learned_note(rr.specs),
        cached_note(cached, page.figs.parent.parent, full=page.full),
        f"\nsogdd's rank per family: {fam_ranks}. The `blur` family (Gaussian σ 0.5-5 px, motion blur "
        "3-15 px at a seeded random angle) is beyond the paper, which claims blur robustness in its "
        "abstract but tests none; it is not in the overall mean.\n",
        f"\n### Both modes: defaults and the {REPEATABILITY_TOP_N} strongest points\n",
        "At defaults R_avg rewards a detector for how many points its threshold returns. In the "
        f"fixed-count mode every detector runs with its threshold off (`permissive()`) and keeps its "
        f"{REPEATABILITY_TOP_N} strongest points (by response) on both images (`--top-n`); where a "
        "detector finds fewer, it keeps them all (see the points column). Not in the paper.\n\n",
        repeatability_modes_table(rr),
        f"![repeatability]({page.rel}/repeatability.png)\n",
        "**What differs from the paper:** 12 images instead of 30; "
        + ("the paper's full grid" if page.full else "a quick grid (fewer parameters per family)")
        + "; the comparators are the registry's OpenCV and re-implemented baselines"
        + (", with the learned XFeat, ALIKED and DISK (not the paper's learned methods)"
           if learned_labels(rr.specs) else " (no learned detectors)")
        + ", not the paper's 16 methods; `blur` and the fixed-count mode are additions. The paper's Fig. 9 "
        "claims that the proposed detector has the best average repeatability under all six families.\n",
    ]
    page.summary["repeatability"] = summ


def downstream_stage(folder: Path, page_dir: Path) -> list[str]:
    """The matching and SfM results already written by ``sogdd eval matching|sfm --out``.

    Those runs take minutes to an hour, so the report includes what was run
    (``<folder>/matching_*/matching.md``, ``<folder>/sfm_*/sfm.md``) rather than
    re-running it.
    """
    parts = sorted(folder.glob("matching_*/matching.md")) + sorted(folder.glob("sfm_*/sfm.md"))
    if not parts:
        return []
    md = ["\n## 6. Image matching (Fig. 10) and 3D reconstruction (Table 2)\n",
          "Included from the runs in `" + os.path.relpath(folder, page_dir) + "` "
          "(commands in docs/matching.md and docs/sfm.md).\n",
          "**What differs from the paper:** the local homography data is 18 pairs (HPatches `v_wormhole`, "
          "Oxford `graf`, the 8 HOMOGR pairs), not the 540 pairs of the full HPatches benchmark; every "
          "detector is described with OpenCV SIFT (the paper's SOSNet weights and REKD orientation filter "
          "are not available), and the learned ones also with their own (`desc=native`); homography AUC is "
          "not in the paper.\n"]
    runs = sorted(folder.glob("matching_*/matching.json")) + sorted(folder.glob("sfm_*/sfm.json"))
    md.append(learned_note(lab for p in runs for lab in json.loads(p.read_text())))
    bud = budget_table(sorted(folder.glob("matching_*/matching.json")))
    if bud:
        md += ["\n### Matching at an equal budget beside the defaults\n", bud]
    # homography accuracy of the detectors at their defaults (the budget runs are in the table above)
    at_defaults = [p for p in sorted(folder.glob("matching_*/matching.json"))
                   if not any(s.get("budget") for s in json.loads(p.read_text()).values())]
    hom = homography_table(at_defaults)
    if hom:
        md += ["\n### Homography accuracy beside MMA\n", hom,
               "HOMOGR's corner errors are large for every detector: its images are up to 1712 px wide with "
               "wide baselines and small planes, so the image corners lie far outside the matched region "
               "(docs/matching.md checks that the ground truth is not the cause).\n"]
    for f in parts:
        body = [ln for ln in f.read_text().splitlines() if not ln.startswith("# ")]
        md += [f"\n### {f.parent.name.replace('_', ' ')}\n", "\n".join(body) + "\n"]
        md.append(_matcher_note(f.with_name("sfm.json")))
        png = f.parent / "mma.png"
        if png.is_file():
            md.append(f"\n![{f.parent.name}]({os.path.relpath(png, page_dir)})\n")
    return md


def _learned_head(page_dir: Path) -> str:
    """The page head's paragraph on the learned rows: which sections have them and what they need."""
    made = ("made with the `learned` extra installed, so GT accuracy (section 1) runs them"
            if learned_extra.installed() else
            "made without the `learned` extra, so GT accuracy (section 1) has no learned rows")
    return ("**Learned detectors** (`xfeat`, `aliked`, `disk`; docs/learned.md): every row of theirs needs "
            f"the `learned` extra to be re-made (`{learned_extra.INSTALL}`); each table says which rows. This "
            f"page was {made}; their repeatability rows (section 2) are read from cached runs in "
            f"`figures/{RUNS_DIR}/` and their matching and SfM rows (section 6) from the runs in "
            "`figures/downstream/`, with or without the extra.\n")


def _matcher_note(sfm_json: Path) -> str:
    """Under an SfM run whose rows were matched differently: which matcher each row had."""
    if not sfm_json.is_file():
        return ""
    by = {}
    for label, r in json.loads(sfm_json.read_text()).items():
        by.setdefault(r.get("matcher") or "colmap", []).append(label)
    if len(by) < 2:
        return ""
    names = {"colmap": "COLMAP's exhaustive matcher", "mnn": "sogdd's mutual-NN matcher (`mnn`)"}
    return ("\nMatchers differ between rows: " + "; ".join(
        f"{names.get(m, f'`{m}`')} for " + ", ".join(f"`{x}`" for x in labs) for m, labs in by.items())
        + " (native descriptors go through `mnn`: COLMAP's matcher takes 128-D SIFT-scaled uint8 "
          "descriptors).\n")


def _commit() -> str:
    """The source tree's git commit, or ``unknown``.

    ``-dirty`` when the package's own files (``src/sogdd``) differ from it; the
    page's outputs, which the report has just rewritten, do not count.
    """
    here = Path(__file__).resolve().parent
    try:
        sha = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=here, capture_output=True,
                             text=True, timeout=10, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", ".."],
                               cwd=here, capture_output=True, text=True, timeout=10, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return sha + ("-dirty" if dirty else "")


def build_report(
    out_md: str | os.PathLike,
    data: str | os.PathLike,
    *,
    full: bool = False,
    jobs: int = 2,
    paper_csv: str | os.PathLike | None = None,
    progress: bool = True,
    resolution_runs: str | os.PathLike | None = None,
    chessboard_quick: bool = False,
    readme: str | os.PathLike | None = None,
    learned_runs: str | os.PathLike | None = None,
) -> Path:
    """Run the stages on ``data`` and write the results page ``out_md`` (see module doc).

    ``resolution_runs`` is the folder of cached full-grid resolution runs
    (default: ``figures/resolution_full`` next to the page, used when it holds
    them and ``full`` is false); ``chessboard_quick`` runs the checkerboards'
    quick grid instead of the full one. ``readme``: a page (the README or, as
    the project does, ``docs/reproducing/index.md``) whose result blocks
    (:mod:`sogdd.report.readme_sync`) are rewritten from this run.
    ``learned_runs``: the folder of the learned detectors' cached repeatability
    runs (default: ``figures/repeatability_learned`` next to the page).
    """
    out_md = Path(out_md)
    data = Path(data)
    figs = out_md.parent / "figures" / "results"
    figs.mkdir(parents=True, exist_ok=True)
    if paper_csv is None:
        cand = data.parent / "reference" / "paper_table1.csv"
        paper_csv = cand if cand.is_file() else None
    page = Page(figs, os.path.relpath(figs, out_md.parent), full, jobs, progress)
    t_all = time.perf_counter()
    gt_stage(page, data, Path(paper_csv) if paper_csv else None)
    repeatability_stage(page, data, learned_runs)
    runs = Path(resolution_runs) if resolution_runs else out_md.parent / "figures" / "resolution_full"
    resolution_stage(page, runs)
    chessboard_stage(page, data, extra=hr_names(), quick=chessboard_quick)
    calibration_stage(page, out_md.parent / "figures" / "calibration")
    fig1_stage(page, data)
    page.md += downstream_stage(out_md.parent / "figures" / "downstream", out_md.parent)
    t_gt = page.seconds["gt"]
    head = [
        "# Results\n",
        "Generated by `sogdd report --out " + str(out_md) + "`"
        + (" --full" if full else "") + f" on {platform.node() or 'this machine'} "
        f"({os.cpu_count()} cores) in {time.perf_counter() - t_all:.0f} s (GT {t_gt:.0f} s), "
        f"sogdd {__version__} at commit `{_commit()}`. Every number can be re-made with the "
        "`sogdd eval` commands.\n",
        "**Data.** `corners_gt/` (W. Zhang et al.'s reference set and the shape set of a hybrid "
        "corner detector study), `repeatability/` (12 photos of Awrangjeb & Lu's set), `calibration/` "
        "(BoofCV's labelled Sony frames), `homography/` (HPatches `v_wormhole`, Oxford `graf`, CMP HOMOGR). "
        "**What differs from the paper:** the GT sets (Geometric: 84 GT corners, not 114; no 'Table'), "
        "the repeatability images (12, not 30), the comparators (the registry's "
        "implementations, see `sogdd.baselines`), the matching data and descriptor; the adjacent-corner, "
        "dense-checkerboard, blur, fixed-count and homography-AUC evaluations are not in the paper. "
        "Each section says what differs.\n",
        _learned_head(out_md.parent),
        "## Summary\n", "\n".join(f"- {x}" for x in page.ranks) + "\n",
    ]
    out_md.parent.mkdir(parents=True, exist_ok=True)
    out_md.write_text("\n".join(head + page.md))
    (figs / "summary.json").write_text(json.dumps({**page.summary, "ranks": page.ranks}, indent=1,
                                                  default=lambda v: None))
    if readme is not None:
        sync_readme(readme, page.readme)
    return out_md
