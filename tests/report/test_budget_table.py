"""The report's matching at an equal budget beside the defaults, with MMA@1."""

import json
from pathlib import Path

import pytest


def _run(folder, results, layout="oxford", seqs=("graf",)):
    folder.mkdir(parents=True)
    bench = {"layout": layout, "n_pairs": 5, "sequences": list(seqs)}
    obj = {k: {**v, "benchmark": bench} for k, v in results.items()}
    (folder / "matching.json").write_text(json.dumps(obj))
    return folder / "matching.json"


def _res(det, mma1, mma3, feats, top_k=None, budget=None, params=None):
    s = {"mma": {"overall": [mma1, 0.0, mma3] + [0.0] * 7}, "features": feats,
         "spec": {"detector": det, "params": params or {}, "remove_border": 0, "top_k": top_k,
                  "descriptor": "sift", "desc_size": "auto"}}
    return {**s, "budget": budget} if budget else s


def test_budget_beside_defaults(tmp_path):
    from sogdd.report.matching import budget_table

    free = _run(tmp_path / "matching_oxford", {
        "sift": _res("sift", 0.19, 0.28, 3086), "sogdd-hr": _res("sogdd-hr", 0.12, 0.25, 5803),
        "sogdd-hr:top_k=2000": _res("sogdd-hr", 0.5, 0.5, 2000, top_k=2000),
        "orb": _res("orb", 0.18, 0.42, 500)})
    assert budget_table([free]) == ""  # no budget run: no table
    capped = _run(tmp_path / "matching_oxford_2000", {
        "sift:top_k=2000": _res("sift", 0.21, 0.30, 2000, 2000, 2000),
        "sogdd-hr:top_k=2000": _res("sogdd-hr", 0.15, 0.31, 2000, 2000, 2000)})
    t = budget_table([free, capped])
    rows = {ln.split("|")[1].strip(): ln for ln in t.splitlines() if ln.startswith("| `")}
    assert set(rows) == {"`sift`", "`sogdd-hr`"}  # orb has no budget run
    assert "| 0.190 / 0.280 (3086) | 0.210 / 0.300 (2000) |" in rows["`sift`"]
    # paired with the default run without a top_k of its own
    assert "| 0.120 / 0.250 (5803) | 0.150 / 0.310 (2000) |" in rows["`sogdd-hr`"]
    assert "defaults | at 2000" in t and "MMA@1 / MMA@3" in t


def test_report_includes_the_budget_table(tmp_path):
    from sogdd.report.results_page import downstream_stage

    folder = tmp_path / "figures" / "downstream"
    _run(folder / "matching_oxford", {"sift": _res("sift", 0.19, 0.28, 3086)})
    _run(folder / "matching_oxford_2000", {"sift:top_k=2000": _res("sift", 0.21, 0.30, 2000, 2000, 2000)})
    for d in ("matching_oxford", "matching_oxford_2000"):
        (folder / d / "matching.md").write_text("| d | MMA@1 |\n")
    text = "\n".join(downstream_stage(folder, tmp_path))
    assert "Matching at an equal budget beside the defaults" in text
    assert "| `sift` | 0.190 / 0.280 (3086) | 0.210 / 0.300 (2000) |" in text


def test_homography_table_holds_the_default_runs_only(tmp_path):
    """A budget run beside its default run adds no second column group to the homography table."""
    import shutil

    from sogdd.report.results_page import downstream_stage

    src = Path(__file__).resolve().parents[2] / "docs" / "figures" / "downstream"
    runs = [src / "matching_oxford", src / "matching_oxford_budget2000"]
    if not all((r / "matching.json").is_file() for r in runs):
        pytest.skip("needs the repository's matching runs")
    for r in runs:
        shutil.copytree(r, tmp_path / r.name)
    md = "\n".join(downstream_stage(tmp_path, tmp_path))
    hom = md.split("### Homography accuracy beside MMA")[1].split("\n\n")[1]
    assert hom.splitlines()[0].count("oxford") == 1
    assert "### Matching at an equal budget beside the defaults" in md
