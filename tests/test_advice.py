"""The README's advice agrees with the numbers: its settings on real photos, its figures with the results.

Every ``detect_corners`` call in the Python blocks of the README and the getting-started page whose
keywords are literals is run on 6 MP photos of the shared data (Fountain-P11): it must give a usable
number of corners, and the counts the README quotes for the presets must be what they give. The
figures of its "use when" table must be those of the generated results pages.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

import sogdd

REPO = Path(__file__).resolve().parents[1]
PAGES = [REPO / "README.md", REPO / "docs" / "getting-started.md"]
BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)
# the photos of Fountain-P11 with the fewest and the most corners at the presets' defaults
FEWEST_PAPER, FEWEST_HR, MOST = "0005.jpg", "0007.jpg", "0010.jpg"


def advised_calls() -> list[dict]:
    """The keywords of every ``detect_corners(img, ...)`` call with literal keywords, in the pages' blocks."""
    calls = []
    for page in PAGES:
        if not page.is_file():
            continue
        for block in BLOCK.findall(page.read_text()):
            for node in ast.walk(ast.parse(block)):
                if not (isinstance(node, ast.Call) and getattr(node.func, "attr", None) == "detect_corners"):
                    continue
                try:
                    kw = {k.arg: ast.literal_eval(k.value) for k in node.keywords}
                except ValueError:  # a keyword that is not a literal (a mask): not a setting to check
                    continue
                if kw not in calls:
                    calls.append(kw)
    return calls


def test_the_pages_advise_the_calls_this_test_runs():
    calls = advised_calls()
    assert {} in calls  # the default
    assert {"preset": "hr"} in calls
    assert {"threshold": None, "max_corners": 2000} in calls  # a fixed budget


@pytest.fixture(scope="module")
def photos(data_dir):
    folder = data_dir / "multiview" / "fountain-P11" / "images"
    if not (folder / MOST).is_file():
        pytest.skip(f"{folder} is not there")
    return {name: sogdd.read_image(folder / name) for name in (FEWEST_PAPER, FEWEST_HR, MOST)}


def _name(kw: dict) -> str:
    return ",".join(f"{k}={v}" for k, v in kw.items()) or "default"


@pytest.mark.parametrize("kw", advised_calls(), ids=_name)
def test_every_advised_call_gives_a_usable_number_of_corners(photos, kw):
    for name, img in photos.items():
        n = len(sogdd.detect_corners(img, **kw))
        # a 6 MP photo: enough points to match or calibrate with, not one per few hundred pixels
        assert 100 <= n <= 20_000, (kw, name, n)
        if kw.get("max_corners"):
            assert n <= kw["max_corners"], (kw, name, n)
        if kw.get("max_corners") and "threshold" in kw and kw["threshold"] is None:
            # a budget without a threshold is filled (the refinement may merge a point or two onto another)
            assert n >= 0.99 * kw["max_corners"], (kw, name, n)


def _quoted_range(text: str, pattern: str) -> tuple[int, int]:
    m = re.search(pattern, text.replace("\n", " "))
    assert m, pattern
    return int(m.group(1).replace(",", "")), int(m.group(2).replace(",", ""))


def test_the_readme_s_corner_counts_are_what_the_presets_give(photos):
    text = (REPO / "README.md").read_text()
    lo, hi = _quoted_range(text, r"between ([\d,]+) and ([\d,]+) corners on the 6 MP photos of Fountain-P11")
    hr_lo, hr_hi = _quoted_range(text, r"`hr`'s 20 grey levels between ([\d,]+) and ([\d,]+)")
    paper = {name: len(sogdd.detect_corners(img)) for name, img in photos.items()}
    hr = {name: len(sogdd.detect_corners(img, preset="hr")) for name, img in photos.items()}
    # the README rounds: to within 5 %
    assert paper[FEWEST_PAPER] == pytest.approx(lo, rel=0.05)
    assert paper[MOST] == pytest.approx(hi, rel=0.05)
    assert hr[FEWEST_HR] == pytest.approx(hr_lo, rel=0.05)
    assert hr[MOST] == pytest.approx(hr_hi, rel=0.05)


def test_a_relative_threshold_of_one_percent_is_not_advice(photos):
    """``threshold_rel=0.01`` keeps a few dozen corners of a 6 MP photo: the pages must not recommend it."""
    n = len(sogdd.detect_corners(photos[MOST], threshold=None, threshold_rel=0.01))
    assert n < 100
    assert all(kw.get("threshold_rel") != 0.01 for kw in advised_calls())


# ----------------------------------------------------------------------------- the figures beside the advice

RESULTS = REPO / "docs" / "results.md"


def _table_row(section: str, first_cell: str) -> list[str]:
    """The cells of the row starting with ``first_cell`` in the first table after the heading ``section``."""
    text = RESULTS.read_text()
    start = text.index(f"\n### {section}\n")
    for line in text[start:].splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("|") and cells[0] == first_cell:
            return cells
    raise AssertionError(f"{first_cell} not in {section}")


def _use_when_row(job: str) -> str:
    text = (REPO / "README.md").read_text()
    return next(line for line in text.splitlines() if line.startswith(f"| {job} |"))


@pytest.mark.skipif(not RESULTS.is_file(), reason="needs the repository checkout")
def test_the_use_when_table_quotes_the_results_page():
    """Each figure of the README's matching and SfM advice is the generated results page's, rounded."""
    row = _use_when_row("matching, structure from motion")
    mma3 = {d: float(_table_row("matching hpatches budget2000", f"`{d}:top_k=2000`")[3])
            for d in ("sogdd", "sogdd-hr", "sift", "akaze")}
    native = "`{}:top_k=2000:desc=native`"
    mma3 |= {d: float(_table_row(f"matching hpatches budget2000 learned{s}", native.format(d))[3])
             for d, s in (("aliked", ""), ("disk", " disk"))}
    assert (f"MMA@3 is {mma3['sogdd']:.3f} (`paper`) and {mma3['sogdd-hr']:.3f} (`hr`) against SIFT's "
            f"{mma3['sift']:.3f}, AKAZE's {mma3['akaze']:.3f}") in row
    assert f"{min(mma3['aliked'], mma3['disk']):.3f}–{max(mma3['aliked'], mma3['disk']):.3f}" in row
    # the learned detectors are the better choice there: the advice and the figures agree
    assert max(mma3["aliked"], mma3["disk"]) > mma3["sift"] > max(mma3["sogdd"], mma3["sogdd-hr"])
    hr, sift = (_table_row("sfm fountain-P11 budget2000", f"`{d}:top_k=2000`") for d in ("sogdd-hr", "sift"))
    reproj = [float(r[6].split()[0]) for r in (hr, sift)]
    rot = [float(r[9].split()[0]) for r in (hr, sift)]
    assert f"reprojection error is {reproj[0]:.2f} px against SIFT's {reproj[1]:.2f}" in row
    assert f"rotation error {rot[0]:.3f}° against {rot[1]:.3f}°" in row
    assert reproj[0] > reproj[1] and rot[0] > rot[1]


@pytest.mark.skipif(not RESULTS.is_file(), reason="needs the repository checkout")
def test_the_use_when_table_quotes_the_ground_truth_block():
    from sogdd.report.readme_sync import readme_blocks

    gt = readme_blocks((REPO / "docs" / "reproducing" / "index.md").read_text())["gt"]
    f1 = {}
    for line in gt.splitlines():
        cells = [c.strip().strip("*") for c in line.strip().strip("|").split("|")]
        if len(cells) == 6 and cells[0] in ("sogdd", "sogdd-hr"):
            f1[cells[0]] = (float(cells[2]), float(cells[5]))  # default F1, one-threshold F1
    rank = re.search(r"sogdd ranks (\d+ of \d+) with one threshold", gt).group(1)
    assert f"ranks {rank} detectors with one threshold (F1 {f1['sogdd'][1]:.3f})" in _use_when_row(
        "reproducing the paper")
    assert f"(F1 {f1['sogdd-hr'][0]:.3f} there)" in _use_when_row("the most accurate corners")
