"""The ``authors`` preset at the border of the valid area: maxima of the valid area alone.

The authors' code crops the ``border`` px frame away and runs its 3x3 maximum
filter (scipy, mode ``reflect``) and its threshold on what remains, so nothing
beyond the valid area can suppress a peak on its last row or column.
"""

import numpy as np
import pytest
from scipy import ndimage

import sogdd
from sogdd.select.peaks import select_peaks


def authors_rule(resp, border, thr):
    """(row, col) set of the authors' peaks: 3x3 maximum filter on the valid area, strictly above thr."""
    h, w = resp.shape
    v = resp[border : h - border, border : w - border]
    r, c = np.nonzero((v == ndimage.maximum_filter(v, size=3, mode="reflect")) & (v > thr))
    return set(zip((r + border).tolist(), (c + border).tolist()))


def as_set(rows, cols):
    return set(zip(rows.tolist(), cols.tolist()))


def test_peak_on_the_last_valid_row_and_column_survives_a_larger_pixel_beyond():
    resp = np.zeros((20, 24))
    b = 3
    resp[b, 10], resp[b - 1, 10] = 5.0, 9.0  # first valid row, a larger pixel just outside
    resp[12, 24 - b - 1], resp[13, 24 - b] = 4.0, 8.0  # last valid column, larger diagonal beyond
    resp[0, 0] = 20.0  # strongest of all, but outside the valid area
    want = authors_rule(resp, b, 1.0)
    assert want == {(b, 10), (12, 24 - b - 1)}
    assert as_set(*select_peaks(resp, threshold=1.0, border=b)) == want


@pytest.mark.parametrize("seed", range(4))
def test_select_peaks_equals_the_authors_rule_on_random_maps(seed):
    rng = np.random.default_rng(seed)
    resp = rng.standard_normal((40, 50))
    border = int(rng.integers(1, 6))
    v = resp[border:-border, border:-border]
    thr = float(np.quantile(v[v > 0], 0.5))
    want = authors_rule(resp, border, thr)
    got = select_peaks(resp, quantile=0.5, border=border)
    assert as_set(*got) == want
    # random maps have peaks on the valid area's edge: the case is exercised
    assert any(r in (border, 40 - border - 1) or c in (border, 50 - border - 1) for r, c in want)


def test_authors_preset_matches_the_rule_end_to_end():
    """Whole detector, noise image: its corners are the authors' peaks of its own response map."""
    img = np.random.default_rng(7).uniform(0, 255, (64, 80)).astype(np.uint8)
    resp = sogdd.corner_response(img, preset="authors")
    v = resp[9:-9, 9:-9]
    thr = np.quantile(v[np.isfinite(v) & (v > 0)], 0.99)
    want = authors_rule(resp, 9, thr)
    c = sogdd.detect_corners(img, preset="authors")
    assert as_set(c.xy[:, 1].astype(int), c.xy[:, 0].astype(int)) == want


def test_border_zero_is_unchanged():
    rng = np.random.default_rng(3)
    resp = rng.standard_normal((30, 30))
    rows, cols = select_peaks(resp, threshold=0.5)
    ref = (resp > 0.5) & (resp == ndimage.maximum_filter(resp, size=3, mode="constant", cval=-np.inf))
    assert as_set(rows, cols) == set(zip(*(a.tolist() for a in np.nonzero(ref))))
