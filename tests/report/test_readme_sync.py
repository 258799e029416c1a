"""Generated figures on the documentation pages come from the commands that make them (report.readme_sync)."""

from pathlib import Path

import cv2
import pytest

from sogdd.evaluation.gt import evaluate_gt, find_gt_sets, write_corners_csv
from sogdd.evaluation.specs import DetectorSpec
from sogdd.report.readme_sync import readme_blocks, sync_readme
from sogdd.report.tables import gt_readme_table
from sogdd.synthetic import pattern_image

DOCS = Path(__file__).resolve().parents[2] / "docs"
# the pages that hold the generated blocks, as CONTRIBUTING.md's commands write them
GT_PAGE = DOCS / "reproducing" / "index.md"
EXACTNESS_PAGE = DOCS / "explanations" / "exactness.md"


@pytest.mark.skipif(not DOCS.is_dir(), reason="needs the repository checkout")
def test_the_docs_figures_are_generated_blocks():
    gt = readme_blocks(GT_PAGE.read_text())
    assert set(gt) == {"gt"}
    assert gt["gt"].startswith("| detector | default M+F |")
    assert "sogdd ranks" in gt["gt"]
    exact = readme_blocks(EXACTNESS_PAGE.read_text())
    assert set(exact) == {"exactness"}
    assert exact["exactness"].startswith("| image | preset |")


@pytest.mark.skipif(not DOCS.is_dir(), reason="needs the repository checkout")
def test_the_commands_that_write_the_blocks_name_those_pages():
    """CONTRIBUTING.md's regeneration commands point at the pages that hold the blocks."""
    text = (DOCS.parent / "CONTRIBUTING.md").read_text()
    assert "sogdd report --out docs/results.md --readme docs/reproducing/index.md" in text
    assert "bench_exactness.py --readme docs/explanations/exactness.md" in text


def test_a_missing_block_is_an_error_and_the_file_is_untouched(tmp_path):
    p = tmp_path / "README.md"
    p.write_text("no blocks here\n")
    with pytest.raises(ValueError, match="results:gt"):
        sync_readme(p, {"gt": "x"})
    assert p.read_text() == "no blocks here\n"


def test_the_gt_block_is_the_gt_run_s_numbers(tmp_path):
    img, corners = pattern_image((160, 240), seed=4)
    d = tmp_path / "one"
    d.mkdir()
    cv2.imwrite(str(d / "image.png"), img)
    write_corners_csv(d / "corners.csv", corners[::2])
    rep = evaluate_gt(find_gt_sets(d), [DetectorSpec("sogdd"), DetectorSpec("harris")], progress=False)
    table = gt_readme_table(rep)
    j = rep.pooled("sogdd", "joint")
    de = rep.pooled("sogdd", "default")
    assert f"| **sogdd** | {de.missed + de.false} |" in table
    assert f"| {j.missed + j.false} |" in table.split("**sogdd**")[1].splitlines()[0]
    p = tmp_path / "README.md"
    p.write_text("a\n<!-- results:gt -->\nstale\n<!-- /results:gt -->\nb\n")
    assert sync_readme(p, {"gt": table}) == ["gt"]
    assert readme_blocks(p.read_text())["gt"] == table
    assert sync_readme(p, {"gt": table}) == []  # unchanged: nothing rewritten
