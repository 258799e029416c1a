"""The settings the README and the getting-started page recommend give sensible corners on real photos.

Every ``detect_corners`` call in their Python blocks whose keywords are literals is run on 6 MP photos of
the shared data (Fountain-P11): it must give a usable number of corners, and the counts the README quotes
for the presets must be what they give.
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
