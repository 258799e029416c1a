"""The fixed-count mode of the learned entries: ``top_n`` switches the score threshold off, not only the budget.

ALIKED's and DISK's default budget is already "all" (``max_corners=-1``), so
a permissive run that only lifted the budget was the default run, threshold
included, and ``top_n(500)`` gave fewer than 500 points wherever the default
found fewer (the repeatability page's ALIKED row: 360 points per image). The
tests skip, with the reason, where the ``learned`` extra is not installed.
"""

import pytest

from sogdd import baselines
from sogdd.synthetic import pattern_image

NEEDS_EXTRA = pytest.mark.learned  # skipped with the reason without the extra (tests/conftest.py)


@pytest.fixture(scope="module")
def scene():
    img, _ = pattern_image((256, 320), seed=3)
    return img


@NEEDS_EXTRA
@pytest.mark.parametrize("name", ["xfeat", "aliked", "disk"])
def test_top_n_reaches_n_where_the_default_finds_fewer(name, scene):
    det = baselines.get(name, device="cpu")
    n = 500
    default = det.detect_corners(scene)
    assert len(default) < n  # the pattern's corners are few: the threshold is what limits the default
    top = det.top_n(scene, n)
    assert len(top) == n
    loose = det.permissive()
    assert loose.params["max_corners"] == -1
    assert loose.params["detection_threshold"] != det.params["detection_threshold"]
    # the strongest default points are the strongest points with the threshold off as well
    assert top.response[0] == pytest.approx(default.response[0], rel=1e-5)


@NEEDS_EXTRA
@pytest.mark.parametrize("name", ["aliked", "disk"])
def test_the_threshold_off_run_keeps_the_other_settings(name):
    """Only the budget and the score threshold change; the scaling and the device stay."""
    det = baselines.get(name, device="cpu", max_side=512)
    assert det.permissive().params["max_side"] == 512
    assert det.permissive().params["device"] == "cpu"
