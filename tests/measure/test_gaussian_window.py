"""The Gaussian-window SODDC measure (sogdd.measure.gaussian_window) against its literal definition."""

from __future__ import annotations

import numpy as np
import pytest

import sogdd
from sogdd.measure.gaussian_window import gaussian_window_reference, gaussian_window_spec
from sogdd.measure.soddc import soddc_measure


@pytest.mark.parametrize("spec", [gaussian_window_spec(1.2, 4, 3), gaussian_window_spec(2.0, 8, 5),
                                  gaussian_window_spec(1.44, 4, 3, "authors", True)])
def test_gaussian_window_measure_equals_the_definition(spec):
    rng = np.random.default_rng(7)
    img = rng.uniform(0, 255, (37, 45))
    img[10:25, 12:30] += 60.0  # a rectangle: corners and edges among the noise
    fast = soddc_measure(img, spec)
    ref = gaussian_window_reference(img, spec)
    assert np.max(np.abs(fast - ref)) <= 1e-9 * np.max(np.abs(ref))


def test_gaussian_window_through_the_api():
    img, _ = sogdd.synthetic.pattern_image((120, 160))
    r = sogdd.corner_response(img, n_orientations=4, window=3, window_shape="gaussian")
    ref = gaussian_window_reference(img.astype(np.float64), gaussian_window_spec(1.2, 4, 3))
    np.testing.assert_allclose(r, ref, rtol=0, atol=1e-9 * ref.max())
    with pytest.raises(ValueError, match="window_shape='gaussian' needs"):
        sogdd.detect_corners(img, window_shape="gaussian", padding="image")
