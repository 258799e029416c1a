"""Detection in bands of rows (sogdd.select.bands) against selection on the whole map."""

import numpy as np
import pytest

import sogdd
from sogdd.measure.soddc import soddc_measure
from sogdd.select.bands import stream_peaks
from sogdd.select.peaks import select_peaks
from sogdd.select.refine import refine_quadratic


@pytest.mark.parametrize("band_rows", [1, 5, 17, 1024])
@pytest.mark.parametrize("kw", [{}, {"nms_radius": 3}, {"border": 6}, {"border": 1, "max_corners": 25},
                                {"border": 200}])
def test_bands_give_the_peaks_of_the_whole_map(pattern, rng, band_rows, kw):
    img = np.clip(pattern[0] + rng.normal(0, 4, pattern[0].shape), 0, 255)
    spec = sogdd.resolve_params("paper").measure_spec()
    mask = rng.random(img.shape) < 0.9
    thr = 1e8
    full = soddc_measure(img, spec)
    rows, cols = select_peaks(full, threshold=thr, mask=mask, **kw)
    r, c, v, off = stream_peaks(img, spec, threshold=thr, floor=thr, mask=mask, band_rows=band_rows,
                                quadratic=True, **kw)
    if kw.get("border") != 200:
        assert len(rows) > 10
    np.testing.assert_array_equal(r, rows)
    np.testing.assert_array_equal(c, cols)
    np.testing.assert_array_equal(v, full[rows, cols])
    np.testing.assert_array_equal(off, refine_quadratic(full, rows, cols))


def test_bands_find_peaks_on_the_first_and_last_rows():
    """Edge peaks (shifted 3x3 patches) and a band boundary next to a peak."""
    img = np.zeros((23, 40))
    img[:6, :10] = 200.0  # corners near row 0 ...
    img[17:, 25:] = 200.0  # ... and near the last row
    img[9:14, 15:20] = 255.0
    spec = sogdd.resolve_params("paper").measure_spec()
    full = soddc_measure(img, spec)
    thr = float(np.quantile(full[full > 0], 0.5))
    rows, cols = select_peaks(full, threshold=thr)
    for band_rows in (2, 3, 11):
        r, c, v, off = stream_peaks(img, spec, threshold=thr, floor=thr, band_rows=band_rows, quadratic=True)
        np.testing.assert_array_equal(np.stack([r, c]), np.stack([rows, cols]))
        np.testing.assert_array_equal(off, refine_quadratic(full, rows, cols))


@pytest.mark.parametrize("preset", ["paper", "authors", "hr"])
def test_uint8_grey_is_measured_as_it_is(pattern, rng, preset):
    """A uint8 grey image reaches the filters without a float64 copy, with the float64 image's values."""
    img8 = np.clip(pattern[0] + rng.normal(0, 4, pattern[0].shape), 0, 255).astype(np.uint8)
    spec = sogdd.resolve_params(preset).measure_spec()
    for kw in ({}, {"threads": 1, "tile_rows": 7}):
        got = soddc_measure(img8, spec, raw=spec.authors_measure, **kw)
        want = soddc_measure(img8.astype(np.float64), spec, raw=spec.authors_measure, **kw)
        np.testing.assert_array_equal(got, want)
    # the banded detector takes that path from a uint8 input; with a value range (the same grey
    # values, converted to float64 band by band) it gives the same corners
    a = sogdd.detect_corners(img8, preset=preset)
    b = sogdd.detect_corners(img8, preset=preset, value_range=(0, 255))
    assert len(a) > 10
    np.testing.assert_array_equal(a.xy, b.xy)
