"""Report tables and the results page on a tiny data root."""

import math

import cv2
import numpy as np
import pytest

from sogdd.evaluation.gt import evaluate_gt, find_gt_sets, write_corners_csv
from sogdd.evaluation.specs import DetectorSpec
from sogdd.report.results_page import rank_of
from sogdd.report.tables import fmt, gt_summary_table, gt_table, markdown_table
from sogdd.synthetic import pattern_image as make_pattern


def test_markdown_table_and_fmt():
    t = markdown_table(["a", "b"], [["x", 1.23456], ["y", float("nan")]])
    lines = t.strip().splitlines()
    assert lines[0] == "| a | b |" and lines[2] == "| x | 1.235 |" and "–" in lines[3]
    assert fmt(3) == "3" and fmt(1e9) == "1e+09" and fmt(None) == "–"


def test_rank_of():
    assert rank_of({"a": 0.5, "b": 0.9, "c": math.nan}, "a") == (2, 3)
    assert rank_of({"a": 3.0, "b": 1.0}, "a", higher_is_better=False) == (2, 2)


def test_gt_tables(tmp_path):
    img, corners = make_pattern((160, 240), seed=4)
    d = tmp_path / "one"
    d.mkdir()
    cv2.imwrite(str(d / "image.png"), img)
    write_corners_csv(d / "corners.csv", corners[::2])  # half the corners: the rest is false
    rep = evaluate_gt(find_gt_sets(d), [DetectorSpec("sogdd")], progress=False)
    e = rep.entry("sogdd", "one")
    assert e.default.false >= len(corners) // 2 - 2
    assert e.consistency == 1.0
    s = gt_summary_table(rep)
    assert "sogdd" in s and s.count("\n") == 3
    t = gt_table(rep, "tuned")
    assert f"| sogdd | {e.tuned.missed} | {e.tuned.false} |" in t
    assert np.isfinite(rep.joint_threshold["sogdd"])


def test_report_includes_downstream_runs(tmp_path):
    from sogdd.report.results_page import downstream_stage as _downstream_sections

    folder = tmp_path / "figures" / "downstream"
    assert _downstream_sections(folder, tmp_path) == []
    (folder / "sfm_chair").mkdir(parents=True)
    (folder / "sfm_chair" / "sfm.md").write_text("# SfM\n| method | points |\n|---|---|\n| sogdd | 573 |\n")
    (folder / "matching_oxford").mkdir(parents=True)
    (folder / "matching_oxford" / "matching.md").write_text("# MMA\n| d | MMA@1 |\n")
    (folder / "matching_oxford" / "mma.png").write_bytes(b"png")
    text = "\n".join(_downstream_sections(folder, tmp_path))
    assert "| sogdd | 573 |" in text and "MMA@1" in text
    assert text.index("matching oxford") < text.index("sfm chair")
    assert "figures/downstream/matching_oxford/mma.png" in text
    assert "# SfM" not in text


# ------------------------------------------------------------------ the results page's sections
def _page(tmp_path):
    from sogdd.report.results_page import Page

    figs = tmp_path / "figures" / "results"
    figs.mkdir(parents=True)
    return Page(figs, "figures/results", progress=False)


def _res_report(detectors, mode="default", resolved=None, quick=False):
    """A hand-made resolution run over 4 configurations (no rendering)."""
    from sogdd.evaluation.resolution import ResolutionReport

    cfgs = [("END", 2.0), ("END", 4.0), ("L", 2.0), ("L", 4.0)]
    recs = []
    for k, det in enumerate(detectors):
        for i, (kind, d) in enumerate(cfgs):
            ok = resolved[k][i] if resolved else bool((i + k) % 2)
            recs.append({"detector": det, "kind": kind, "d": d, "alpha": 0.5, "beta": 0.5, "noise": 0.0,
                         "resolved": ok, "dist": [0.1 * (i + 1), 0.123456789] if ok else [0.7]})
    return ResolutionReport(recs, list(detectors), 1.5, quick, mode, 2.0)


def test_resolution_records_roundtrip_and_merge(tmp_path):
    from sogdd.evaluation.resolution.protocol import load_records

    rep = _res_report(["sogdd", "harris"])
    paths = rep.write(tmp_path)
    back = load_records(tmp_path / "resolution_records.json")
    assert tmp_path / "resolution_records.json" in paths
    assert back.detectors == ["sogdd", "harris"]
    for d in rep.detectors:
        assert back.rate(d) == rep.rate(d) and back.rate(d, kind="L") == rep.rate(d, kind="L")
        assert back.le(d) == pytest.approx(rep.le(d), abs=1e-5)  # distances kept to 1e-5 px
    merged = back.merged(_res_report(["fast"]))
    assert merged.detectors == ["sogdd", "harris", "fast"] and len(merged.records) == 12
    with pytest.raises(ValueError, match="detectors in both"):
        back.merged(_res_report(["harris"]))
    with pytest.raises(ValueError, match="different"):
        back.merged(_res_report(["fast"], quick=True))
    (tmp_path / "bad.json").write_text('{"format": "other"}')
    with pytest.raises(ValueError, match="bad.json"):
        load_records(tmp_path / "bad.json")


def test_resolution_stage_reads_cached_runs(tmp_path):
    from sogdd.report.resolution_section import load_runs, resolution_stage

    runs = tmp_path / "runs"
    _res_report(["sogdd", "harris"], resolved=[[1, 1, 0, 1], [0, 0, 0, 0]]).write(runs)
    assert load_runs(runs) is None  # the oracle run and the sweep are missing
    _res_report(["sogdd", "harris"], mode="oracle").write(runs)
    _res_report(["sogdd:sigma2=1", "sogdd:sigma2=2"], mode="oracle").write(runs / "sigma2")
    _res_report(["sogdd-hr"], resolved=[[1, 1, 1, 1]]).write(runs / "hr")  # a detector run later
    _res_report(["sogdd-hr"], mode="oracle").write(runs / "hr")
    page = _page(tmp_path)
    resolution_stage(page, runs)
    text = "\n".join(page.md)
    assert "Read from the cached runs in `runs` (made by `sogdd eval resolution --out " in text
    assert "--mode oracle --sweep-sigma2 --out " in text and "sub-folder(s) `hr/`" in text
    assert "| sogdd-hr | 1.000 | 1.000 |" in text  # merged from the sub-folder
    assert page.summary["resolution_default"]["sogdd"] == 0.75
    assert page.summary["resolution_grid"] == {"full": True, "configurations": 4, "cached": True}
    assert "sogdd ranks **2 of 3** at default" in page.ranks[0]
    assert (page.figs / "resolution_oracle.png").stat().st_size > 0


def test_chessboard_stage_tiny(tmp_path):
    from sogdd.report.chessboard_section import chessboard_rows, chessboard_stage

    assert chessboard_rows(["sogdd-hr"])[:3] == ["sogdd", "sogdd-authors", "sogdd-hr"]
    page = _page(tmp_path)
    chessboard_stage(page, tmp_path, cells=[8], quick=True)  # no calibration/ under tmp_path
    text = "\n".join(page.md)
    assert "## 4. Dense checkerboards" in text and "Real calibration" not in text
    row = next(ln for ln in text.splitlines() if ln.startswith("| sogdd |"))
    rec = page.summary["chessboard"]["recall"]["sogdd"]
    assert f" / {rec:.2f} / " in row
    assert "What differs from the paper" in text and (page.figs / "chessboard.png").is_file()


def test_fig1_stage_tiny(tmp_path):
    from sogdd.report.fig1_section import fig1_stage

    page = _page(tmp_path)
    fig1_stage(page, tmp_path)
    assert "Skipped" in page.md[-1]
    img, corners = make_pattern((120, 160), seed=3)
    d = tmp_path / "corners_gt" / "geometric"
    d.mkdir(parents=True)
    cv2.imwrite(str(d / "image.png"), img)
    write_corners_csv(d / "corners.csv", corners)
    page = _page(tmp_path / "p")
    fig1_stage(page, tmp_path)
    text = "\n".join(page.md)
    f = page.summary["fig1"]
    assert f"at σ² = 5 the edge point out-responds the corner at {f['edge_wins'][5.0]} of the 8" in text
    assert 0 <= f["edge_wins"][2.0] <= 8 and f["gap"] > 0
    assert (page.figs / "fig1_detections.png").is_file() and (page.figs / "fig1_sogdd_theta.png").is_file()


def test_homography_table_beside_mma(tmp_path):
    import json

    from sogdd.report.matching import homography_table

    def run(name, layout, hom):
        d = tmp_path / name
        d.mkdir()
        s = {"mma": {"overall": [0.1, 0.2, 0.345, 0.4]}, "benchmark": {"layout": layout, "n_pairs": 5,
                                                                          "sequences": ["graf"]}}
        if hom:
            s["homography"] = {"auc": {"overall": [0.25, 0.5, 0.625]}, "median_corner_error": 1.234,
                               "failed": 1}
        (d / "matching.json").write_text(json.dumps({"sogdd": s}))
        return d / "matching.json"

    t = homography_table([run("a", "oxford", True), run("b", "homogr", False)])
    row = next(ln for ln in t.splitlines() if ln.startswith("| `sogdd` |"))
    assert "0.345 / 0.250 / 0.500 / 0.625 / 1.23 (1 failed)" in row
    assert "0.345 / – / – / – / –" in row  # a run made before homography accuracy existed
    assert "oxford `graf` (5 pairs)" in t and homography_table([]) == ""
