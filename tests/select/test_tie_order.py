"""Equal peaks keep raster order: among corners of equal strength, the first in raster order comes first,
is kept by max_corners, and wins a plateau."""

from __future__ import annotations

import numpy as np
import pytest

import sogdd
from sogdd.select.peaks import select_peaks


@pytest.fixture(scope="module")
def squares():
    """20 identical squares on a grid: each of their four corner types ties exactly, 20 times over."""
    img = np.zeros((160, 192), np.uint8)
    for y in range(24, 140, 32):
        for x in range(24, 170, 32):
            img[y : y + 10, x : x + 10] = 200
    return img


def _raster_within_ties(c: sogdd.Corners) -> None:
    values, first, counts = np.unique(c.response, return_index=True, return_counts=True)
    assert counts.max() >= 20  # the scene does tie
    for v in values:
        idx = np.flatnonzero(c.response == v)
        assert np.all(np.diff(idx) == 1)  # equal values are adjacent in the strongest-first order
        yx = c.xy[idx][:, ::-1]
        assert [tuple(p) for p in yx] == sorted(tuple(p) for p in yx), v  # and in raster order


@pytest.mark.parametrize("params", [
    {},  # the absolute threshold: band by band
    {"threshold": None, "threshold_rel": 0.5},  # a relative threshold
    {"threshold": None, "quantile": 0.5},
])
def test_equal_corners_come_in_raster_order(squares, params):
    c = sogdd.detect_corners(squares, subpixel=False, **params)
    _raster_within_ties(c)


def test_max_corners_keeps_the_first_equal_ones_in_raster_order(squares):
    full = sogdd.detect_corners(squares, subpixel=False)
    top = full.response[0]
    tied = full.xy[full.response == top]
    assert len(tied) == 20
    for k in (1, 7, 13):
        got = sogdd.detect_corners(squares, subpixel=False, max_corners=k)
        want = sorted(map(tuple, tied[:, ::-1]))[:k]  # the first k in raster order (row, then column)
        assert [tuple(p) for p in got.xy[:, ::-1]] == want


@pytest.mark.parametrize("radius", [1, 2])
def test_a_plateau_keeps_its_first_pixel_in_raster_order(radius):
    r = np.zeros((12, 14))
    r[5, 6] = r[5, 7] = 4.0  # a horizontal plateau: the left pixel is first
    r[8, 3] = r[9, 3] = 3.0  # a vertical one: the upper pixel
    r[2, 10] = r[3, 9] = 2.0  # a diagonal one: the upper row, although it lies to the right
    rows, cols = select_peaks(r, threshold=1.0, nms_radius=radius)
    assert list(zip(rows.tolist(), cols.tolist())) == [(5, 6), (8, 3), (2, 10)]
    rows, cols = select_peaks(r, threshold=1.0, nms_radius=radius, max_corners=2)
    assert list(zip(rows.tolist(), cols.tolist())) == [(5, 6), (8, 3)]
