"""The results page says which rows need the ``learned`` extra (and that they are absent without it)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from sogdd.baselines import learned_extra
from sogdd.report import learned_rows
from sogdd.report.learned_rows import learned_labels, learned_note
from sogdd.report.results_page import downstream_stage

DOWNSTREAM = Path(__file__).resolve().parents[2] / "docs" / "figures" / "downstream"


def test_learned_labels_by_registry_family_in_every_label_form():
    labels = ["sogdd", "xfeat", "xfeat:desc=native:top_k=2000", "aliked [top-500]", "disk:max_side=640",
              "sift:top_k=2000", "sogdd-hr", "xfeat"]
    assert learned_labels(labels) == ["xfeat", "xfeat:desc=native:top_k=2000", "aliked [top-500]",
                                      "disk:max_side=640"]
    assert learned_labels(["sift", "harris", "unknown-name"]) == []


@pytest.mark.parametrize("installed", [False, True])
def test_note_names_the_rows_that_need_the_extra(monkeypatch, installed):
    monkeypatch.setattr(learned_extra, "installed", lambda: installed)
    note = learned_note(["sift", "aliked:desc=native", "sogdd"])
    assert "`aliked:desc=native` needs the `learned` extra" in note
    assert learned_extra.INSTALL in note and "`sift`" not in note


def test_note_without_learned_rows_says_they_are_absent_only_without_the_extra(monkeypatch):
    monkeypatch.setattr(learned_extra, "installed", lambda: False)
    note = learned_note(["sift", "sogdd"])
    assert "have no rows here" in note and "not installed" in note
    monkeypatch.setattr(learned_extra, "installed", lambda: True)
    assert learned_note(["sift", "sogdd"]) == ""


def test_downstream_section_marks_learned_rows_of_the_runs(tmp_path, monkeypatch):
    src = DOWNSTREAM / "matching_hpatches" / "matching.json"
    if not src.is_file():
        pytest.skip(f"{src} is not in this checkout")
    monkeypatch.setattr(learned_rows.learned_extra, "installed", lambda: True)
    sift = json.loads(src.read_text())["sift"]
    run = tmp_path / "downstream" / "matching_hpatches"
    run.mkdir(parents=True)
    (run / "matching.json").write_text(json.dumps({"sift": sift, "xfeat:desc=native": sift}))
    (run / "matching.md").write_text("| d | MMA@1 |\n")
    text = "\n".join(downstream_stage(tmp_path / "downstream", tmp_path))
    assert "`xfeat:desc=native` needs the `learned` extra" in text
    assert "`sift` needs" not in text


def test_sfm_runs_with_two_matchers_say_which_row_had_which(tmp_path):
    run = tmp_path / "downstream" / "sfm_set_budget2000"
    run.mkdir(parents=True)
    (run / "sfm.json").write_text(json.dumps({"sift:top_k=2000": {"matcher": "colmap"},
                                              "xfeat:top_k=2000:desc=native": {"matcher": "mnn"}}))
    (run / "sfm.md").write_text("| method | #reg. |\n")
    text = "\n".join(downstream_stage(tmp_path / "downstream", tmp_path))
    assert ("COLMAP's exhaustive matcher for `sift:top_k=2000`; sogdd's mutual-NN matcher (`mnn`) for "
            "`xfeat:top_k=2000:desc=native`") in text
    (run / "sfm.json").write_text(json.dumps({"sift": {"matcher": "colmap"}}))
    assert "Matchers differ" not in "\n".join(downstream_stage(tmp_path / "downstream", tmp_path))


@pytest.mark.parametrize("installed", [False, True])
def test_page_head_says_whether_the_gt_section_has_learned_rows(monkeypatch, installed, tmp_path):
    from sogdd.report import results_page

    monkeypatch.setattr(results_page.learned_extra, "installed", lambda: installed)
    head = results_page._learned_head(tmp_path)
    assert ("so GT accuracy (section 1) runs them" in head) == installed
    assert ("has no learned rows" in head) == (not installed)
    assert "figures/repeatability_learned/" in head and learned_extra.INSTALL in head
