"""The results page reads the learned repeatability rows from cached runs, when their protocol matches.

No PyTorch needed: the cached runs here are made by cheap OpenCV detectors
and relabelled as learned rows, which is all the page sees of a run.
"""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from sogdd.evaluation.repeatability import RUN_FILE, RepeatabilityReport, evaluate_repeatability
from sogdd.evaluation.specs import DetectorSpec
from sogdd.report import results_page
from sogdd.report.learned_runs import cached_note, protocol_differences, read_cached
from sogdd.synthetic import pattern_image

FAMS = ("jpeg", "rotation")


@pytest.fixture(scope="module")
def images():
    return [(f"p{i}.png", pattern_image((120, 160), seed=i)[0][::2, ::2].copy()) for i in (1, 2)]


def run(images, name="harris", label=None, *, quick=True, top_n=20, families=FAMS):
    return evaluate_repeatability(images, [DetectorSpec(name, label=label or name)], families=families,
                                  quick=quick, progress=False, top_n=top_n)


def cache(folder: Path, rep: RepeatabilityReport) -> Path:
    rep.write(folder)
    return folder / RUN_FILE


def test_run_file_round_trip_keeps_protocol_records_and_summary(tmp_path, images):
    rep = run(images)
    back = RepeatabilityReport.from_run_json(json.loads(cache(tmp_path / "r", rep).read_text()))
    assert back.protocol() == rep.protocol()
    assert back.summary() == rep.summary() and back.points() == rep.points()
    assert [r["param"] for r in back.records] == [r["param"] for r in rep.records]
    with pytest.raises(ValueError, match="format 1"):
        RepeatabilityReport.from_run_json({"records": []})


def test_a_matching_cached_run_adds_its_rows(tmp_path, images):
    live = run(images)
    cached = run(images, "shi-tomasi", "xfeat")
    cache(tmp_path / "xfeat", cached)
    found = read_cached(tmp_path, live)
    assert found.stale == [] and [s for _, s in found.used] == [["xfeat"]]
    merged = live.merged(found.report)
    assert merged.specs == ["harris", "xfeat"]
    assert merged.summary()["xfeat [top-20]"] == cached.summary()["xfeat [top-20]"]
    assert merged.summary()["harris"] == live.summary()["harris"]
    note = cached_note(found, tmp_path)
    assert "`xfeat`" in note and "not re-run" in note and "stale" not in note


def test_a_cached_run_with_a_different_grid_is_refused(tmp_path, images):
    live = run(images)
    cache(tmp_path / "xfeat", run(images, "shi-tomasi", "xfeat", quick=False))  # the full grid
    found = read_cached(tmp_path, live)
    assert found.report is None and found.used == []
    (path, why), = found.stale
    assert path == tmp_path / "xfeat" / RUN_FILE
    assert "quick False, not True" in why and "transforms" in " ".join(why)
    note = cached_note(found, tmp_path)
    assert "Left out as stale: `xfeat/repeatability_run.json` (quick False, not True" in note
    assert "No cached learned run matches" in note


def test_other_pixels_top_n_or_images_are_refused(tmp_path, images):
    live = run(images)
    noisy = [images[0], (images[1][0], np.minimum(images[1][1], 254) + np.uint8(1))]
    cache(tmp_path / "a", run(noisy, "shi-tomasi", "xfeat"))
    cache(tmp_path / "b", run(images, "shi-tomasi", "aliked", top_n=30))
    cache(tmp_path / "c", run(images[:1], "shi-tomasi", "disk"))
    why = dict(read_cached(tmp_path, live).stale)
    assert why[tmp_path / "a" / RUN_FILE] == ["image p2.png has other pixels"]
    assert why[tmp_path / "b" / RUN_FILE] == ["top_n 30, not 20"]
    assert why[tmp_path / "c" / RUN_FILE] == ["images 1 (p2.png), not 2"]


def test_a_run_made_before_the_transforms_changed_is_refused(tmp_path, images, monkeypatch):
    from sogdd.evaluation.repeatability import protocol

    cache(tmp_path / "xfeat", run(images, "shi-tomasi", "xfeat"))
    real = protocol.apply_transform

    def brighter(image, tr, seed=0):  # the same grid and images, another transform code
        out, a, valid = real(image, tr, seed=seed)
        return np.minimum(out, 254) + np.uint8(1), a, valid

    monkeypatch.setattr(protocol, "apply_transform", brighter)
    found = read_cached(tmp_path, run(images))
    assert found.report is None
    (_, why), = found.stale
    assert len(why) == 1 and why[0].startswith("transforms ")


def test_duplicate_and_unreadable_runs_are_left_out(tmp_path, images):
    live = run(images)
    cache(tmp_path / "a", run(images, "shi-tomasi", "xfeat"))
    cache(tmp_path / "b", run(images, "fast", "xfeat"))  # a second xfeat: the first stays
    cache(tmp_path / "c", run(images, "fast", "harris"))  # a row the report ran itself
    (tmp_path / "d").mkdir()
    (tmp_path / "d" / RUN_FILE).write_text("{not json")
    found = read_cached(tmp_path, live)
    assert [p.parent.name for p, _ in found.used] == ["a"]
    why = {p.parent.name: w for p, w in found.stale}
    assert why["b"] == ["rows xfeat already on the page"] and why["c"] == ["rows harris already on the page"]
    assert why["d"][0].startswith("unreadable")


def test_protocol_differences_names_each_change():
    a = {"radius": 4.0, "seed": 0, "grid": {"jpeg": ["q=5"], "noise": ["s=1"]}, "images": [["x", "1"]]}
    assert protocol_differences(a, {**a, "seed": 1, "grid": {"jpeg": ["q=5"]}}) == [
        "seed 1, not 0", "grid of noise (0 transforms, not 1)"]
    # another quick flag says the grid differs; the families' grids are not listed again
    full = {**a, "quick": False, "grid": {}}
    assert protocol_differences({**a, "quick": True}, full) == ["quick False, not True"]


def test_the_report_stage_shows_cached_rows_and_names_stale_ones(tmp_path, images, monkeypatch):
    """repeatability_stage end to end, every detector swapped for a cheap one under its own label."""
    real = evaluate_repeatability

    def cheap(imgs, specs, **kw):
        swapped = [DetectorSpec("harris", label=s.label) for s in specs]
        return real(imgs, swapped, families=FAMS, **{k: v for k, v in kw.items() if k != "jobs"})

    monkeypatch.setattr(results_page, "evaluate_repeatability", cheap)
    data = tmp_path / "data"
    (data / "repeatability").mkdir(parents=True)
    for name, img in images:
        cv2.imwrite(str(data / "repeatability" / name), img)
    figs = tmp_path / "site" / "figures" / "results"
    figs.mkdir(parents=True)
    runs = tmp_path / "site" / "figures" / "repeatability_learned"
    cache(runs / "aliked", run(images, "shi-tomasi", "aliked", top_n=results_page.REPEATABILITY_TOP_N))
    cache(runs / "disk", run(images, "shi-tomasi", "disk", top_n=7))
    page = results_page.Page(figs, "figures/results", progress=False)
    results_page.repeatability_stage(page, data)
    text = "\n".join(page.md)
    assert "| aliked |" in text and "| disk |" not in text and "disk [top-" not in text
    assert "`aliked` needs the `learned` extra" in text and "The rows `aliked` (both modes) are read" in text
    assert ("Left out as stale: `figures/repeatability_learned/disk/repeatability_run.json` (top_n 7, not 500)"
            in text)
    assert "aliked" in page.summary["repeatability"] and "disk" not in page.summary["repeatability"]
