"""Report tables and the results page on a tiny data root."""

import math

import cv2
import numpy as np

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
