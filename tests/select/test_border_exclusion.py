"""The border exclusion after sub-pixel refinement: the same on all four sides.

A point is kept when its nearest pixel lies ``border`` px or more from every
edge: columns ``border .. W - 1 - border`` and rows ``border .. H - 1 - border``,
both ends included. An off-by-one on the right or bottom edge only drops the
last allowed column or row, which a test of the left edge alone never sees.
"""

import numpy as np
import pytest
from scipy import ndimage

import sogdd
from sogdd.select.peaks import inside_allowed


@pytest.mark.parametrize("border", [0, 1, 5])
@pytest.mark.parametrize("shape", [(20, 30), (31, 17)])
def test_first_and_last_allowed_pixels_on_every_side(shape, border):
    h, w = shape
    lo, right, bottom = border, w - 1 - border, h - 1 - border
    mid_x, mid_y = w // 2, h // 2
    kept = np.array([[lo, mid_y], [right, mid_y], [mid_x, lo], [mid_x, bottom],
                     [lo, lo], [right, bottom], [right + 0.49, bottom + 0.49], [lo - 0.49, lo - 0.49]])
    dropped = np.array([[lo - 1, mid_y], [right + 1, mid_y], [mid_x, lo - 1], [mid_x, bottom + 1],
                        [right + 0.51, mid_y], [mid_x, bottom + 0.51], [lo - 0.51, mid_y], [mid_x, lo - 0.51]])
    assert inside_allowed(kept, None, border, shape).all()
    assert not inside_allowed(dropped, None, border, shape).any()
    mask = np.ones(shape, bool)
    assert inside_allowed(kept, mask, border, shape).all()


def _blobs(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    img = ndimage.gaussian_filter(rng.uniform(0, 255, (90, 110)), 1.5) * 4 - 380
    return np.clip(img, 0, 255).astype(np.uint8)


def test_detection_keeps_corners_on_the_last_allowed_row_and_column():
    """Corners of a busy image fall on every side's last allowed pixel, and none beyond."""
    b = 7
    on_side = np.zeros(4, int)  # left, right, top, bottom
    for img in (_blobs(5), _blobs(5).T.copy()):
        h, w = img.shape
        c = sogdd.detect_corners(img, threshold=None, threshold_rel=0.001, border=b)
        col, row = np.rint(c.xy).astype(int).T
        assert col.min() >= b and col.max() <= w - 1 - b and row.min() >= b and row.max() <= h - 1 - b
        on_side += [(col == b).sum(), (col == w - 1 - b).sum(), (row == b).sum(), (row == h - 1 - b).sum()]
    assert (on_side > 0).all(), f"no corner on some side's last allowed pixel: {on_side.tolist()}"
